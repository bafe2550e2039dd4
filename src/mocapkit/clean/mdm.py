"""Mean-motion-texture and the movement digression map (Sec. 3.4).

``T̄``: for every (frame, joint), the normalised average of the mean KNN words (over the K
neighbours) of every source word, of every group holding the joint, that covers the frame.
``M = |T - T̄|`` is the geodesic angle between the take's rotation and ``T̄`` (radians). Each joint's
row is divided by a scale (the paper: the row's mean), and ``MDM = 1 - exp(-M²)`` in [0, 1].
"""

from __future__ import annotations

from collections.abc import Sequence

import numba
import numpy as np
from scipy import ndimage

from mocapkit.clean.knn import GroupNeighbours
from mocapkit.core import rotations as rot
from mocapkit.core.runs import true_runs


def word_weights(gn: GroupNeighbours, power: float) -> np.ndarray:
    """(W,) confidence of each source word's neighbours: ``(eps + d)^-power`` with ``d`` the mean
    KNN word distance per kept joint term (so groups of different sizes compare); ``power = 0``
    gives equal weights (the paper)."""
    if power == 0 or gn.distance.size == 0:
        return np.ones(len(gn.starts))
    d = np.where(np.isfinite(gn.distance), gn.distance, np.nan)
    with np.errstate(all="ignore"):
        dm = np.nanmean(d, axis=1) / max(1, len(gn.group.joints) - gn.group.trim)
    dm = np.where(np.isfinite(dm), dm, np.nanmax(dm) if np.isfinite(dm).any() else 1.0)
    eps = 1e-4
    return (eps + dm) ** (-power)


def _accumulate(
    shape: tuple[int, int],
    reference: np.ndarray,
    neighbours: Sequence[GroupNeighbours],
    word_values: Sequence[np.ndarray],
    weights: np.ndarray | None,
    power: float = 0.0,
    outliers: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Weighted sums of the words covering each cell. With ``outliers`` ((F, J) bool), a word
    does not vote for joint ``j`` when it holds an outlier cell on another of its joints (its
    neighbours were matched around that error); cells no clean word covers keep all votes."""
    F, J = shape
    acc = np.zeros((F, J, 4))
    cnt = np.zeros((F, J))
    acc_all = np.zeros((F, J, 4)) if outliers is not None else acc
    cnt_all = np.zeros((F, J)) if outliers is not None else cnt
    for gn, vals in zip(neighbours, word_values, strict=True):
        js = np.asarray(gn.group.joints)
        N = vals.shape[1]
        w_t = np.ones(N) if weights is None else weights
        ww = word_weights(gn, power)
        for w, a in enumerate(gn.starts):
            v = vals[w]  # (N, m, 4)
            if not np.all(np.isfinite(v)):
                continue
            ref = reference[a : a + N][:, js]
            v = np.where(np.sum(v * ref, axis=-1, keepdims=True) < 0, -v, v)
            wt = ww[w] * w_t
            if outliers is not None:
                acc_all[a : a + N, js] += v * wt[:, None, None]
                cnt_all[a : a + N, js] += wt[:, None]
                bad = outliers[a : a + N][:, js].any(axis=0)  # (m,)
                keep = (bad.sum() - bad) == 0
                if not keep.any():
                    continue
                kj = js[keep]
                acc[a : a + N, kj] += v[:, keep] * wt[:, None, None]
                cnt[a : a + N, kj] += wt[:, None]
            else:
                acc[a : a + N, js] += v * wt[:, None, None]
                cnt[a : a + N, js] += wt[:, None]
    if outliers is not None:
        none = cnt <= 0
        acc[none] = acc_all[none]
        cnt[none] = cnt_all[none]
    return acc, cnt


def _finish(
    acc: np.ndarray, cnt: np.ndarray, reference: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    n = np.linalg.norm(acc, axis=-1, keepdims=True)
    ok = (cnt > 0) & (n[..., 0] > 1e-12)
    out = np.where(ok[..., None], acc / np.where(n > 0, n, 1.0), reference)
    return out, ok


def mean_word(gn: GroupNeighbours) -> np.ndarray:
    """(W, N, m, 4) the mean of each source word's usable neighbours, per frame and joint (NaN
    where none)."""
    use = gn.usable_mask()  # (W, K, N, m)
    s = np.sum(gn.words * use[..., None], axis=1)
    n = np.linalg.norm(s, axis=-1, keepdims=True)
    out = s / np.where(n > 0, n, 1.0)
    none = ~use.any(axis=1)  # (W, N, m)
    return np.where(none[..., None], np.nan, out)


def median_word(gn: GroupNeighbours) -> np.ndarray:
    """(W, N, m, 4) the median neighbour of each source word: the KNN word with the least summed
    geodesic distance to the others (an actual motion, as the paper asks), per joint among the
    neighbours usable on all its frames (all found ones where none is; NaN where none found)."""
    W = gn.index.shape[0]
    use = gn.usable_mask().all(axis=2)  # (W, K, m)
    out = np.full(gn.words.shape[:1] + gn.words.shape[2:], np.nan)
    for w in range(W):
        idx = np.flatnonzero(gn.index[w] >= 0)
        if len(idx) == 0:
            continue
        ws = gn.words[w, idx]  # (k, N, m, 4)
        dots = np.abs(np.einsum("anjc,bnjc->abnj", ws, ws))
        cost = np.arccos(np.clip(dots, 0.0, 1.0)).sum(axis=(2, 3)).sum(axis=1)  # (k,)
        ok = use[w, idx]  # (k, m)
        ok = np.where(ok.any(axis=0), ok, True)
        best = np.argmin(np.where(ok, cost[:, None], np.inf), axis=0)  # (m,)
        m = np.arange(ws.shape[2])
        out[w] = ws[best, :, m].transpose(1, 0, 2)
    return out


def mean_texture(
    reference: np.ndarray,
    neighbours: Sequence[GroupNeighbours],
    power: float = 0.0,
    outliers: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """T̄ (F, J, 4) and a (F, J) bool mask of the cells some word covered (others copy
    ``reference``, the analysed texture). ``power``: see :func:`word_weights`; ``outliers``:
    see :func:`_accumulate`."""
    vals = [mean_word(gn) for gn in neighbours]
    acc, cnt = _accumulate(reference.shape[:2], reference, neighbours, vals, None, power, outliers)
    return _finish(acc, cnt, reference)


def median_texture(
    reference: np.ndarray, neighbours: Sequence[GroupNeighbours], power: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """Replacement texture: per frame, the median words covering it blended with triangular
    weights (peak at each word's centre); same shape/mask conventions as :func:`mean_texture`."""
    vals = [median_word(gn) for gn in neighbours]
    N = vals[0].shape[1] if vals else 1
    tri = 1.0 - np.abs(np.arange(N) - (N - 1) / 2) / ((N + 1) / 2)
    acc, cnt = _accumulate(reference.shape[:2], reference, neighbours, vals, tri, power)
    return _finish(acc, cnt, reference)


def digression(texture: np.ndarray, mean_tex: np.ndarray) -> np.ndarray:
    """M = |T - T̄|: (F, J) geodesic angles in radians."""
    return rot.quat_angle(texture, mean_tex)


def movement_digression_map(
    M: np.ndarray,
    scale: str = "mean",
    gain: float = 1.0,
    floor: float = 0.0,
    active: np.ndarray | None = None,
    spread: np.ndarray | None = None,
) -> np.ndarray:
    """MDM = 1 - exp(-(M / s)²) with ``s = max(gain * scale, floor)`` (frames are rows here).

    Args:
        M: (F, J) digression angles (radians).
        scale: "mean" (the paper: each joint's column mean), "median" (column median) or
            "spread" (per cell: ``spread``, how much the KNN words disagree there).
        gain: multiplies the scale (1 in the paper).
        floor: lower bound on the scale in radians.
        active: (J,) bool, joints analysed; others get MDM 0.
        spread: (F, J) for ``scale="spread"`` (:func:`neighbour_spread`).

    Returns:
        (F, J) float64 in [0, 1].
    """
    z = normalised_digression(M, scale, gain, floor, spread)
    out = 1.0 - np.exp(-(z**2))
    if active is not None:
        out[:, ~np.asarray(active, dtype=bool)] = 0.0
    return np.clip(out, 0.0, 1.0)


def normalised_digression(
    M: np.ndarray,
    scale: str = "mean",
    gain: float = 1.0,
    floor: float = 0.0,
    spread: np.ndarray | None = None,
) -> np.ndarray:
    """(F, J) ``M / s``, the ratio :func:`movement_digression_map` feeds into ``1 - exp(-x²)``
    (unbounded, so very large digressions still compare)."""
    M = np.asarray(M, dtype=np.float64)
    if scale == "mean":
        s = M.mean(axis=0) if M.shape[0] else np.ones(M.shape[1])
    elif scale == "median":
        s = np.median(M, axis=0) if M.shape[0] else np.ones(M.shape[1])
    elif scale == "spread":
        if spread is None or np.shape(spread) != M.shape:
            raise ValueError("scale='spread' needs a spread array shaped like M")
        s = np.asarray(spread, dtype=np.float64)
    else:
        raise ValueError(f"scale must be 'mean', 'median' or 'spread', got {scale!r}")
    s = np.maximum(gain * s, max(float(floor), 1e-12))
    return M / s


def neighbour_spread(reference: np.ndarray, neighbours: Sequence[GroupNeighbours]) -> np.ndarray:
    """(F, J) how much the KNN words disagree: per word, frame and joint the mean geodesic angle
    of the K neighbours from their mean, averaged over the words covering each cell (radians;
    0 where no word covers it)."""
    F, J = reference.shape[:2]
    acc = np.zeros((F, J))
    cnt = np.zeros((F, J))
    for gn in neighbours:
        js = np.asarray(gn.group.joints)
        mw = mean_word(gn)  # (W, N, m, 4)
        N = gn.words.shape[2] if gn.words.ndim == 5 else 0
        use = gn.usable_mask()  # (W, K, N, m)
        for w, a in enumerate(gn.starts):
            ok = use[w]  # (K, N, m)
            if not ok.any():
                continue
            ang = rot.quat_angle(gn.words[w], np.nan_to_num(mw[w])[None])  # (K, N, m)
            n_ok = ok.sum(axis=0)  # (N, m)
            acc[a : a + N, js] += np.sum(ang * ok, axis=0) / np.maximum(n_ok, 1)
            cnt[a : a + N, js] += n_ok > 0
    return np.where(cnt > 0, acc / np.where(cnt > 0, cnt, 1.0), 0.0)


# ------------------------------------------------------------------------------ detection
# The MDM compares a cell with its KNN words only. Two cues from the take's own time axis
# complement it (measured on injected errors in Bandai takes, bench/eval_clean.py): capture
# errors are abrupt (a jump away from the joint's smooth trajectory and back) and a frozen
# joint holds a value exactly while its neighbours move on.


def angular_acceleration(rotations: np.ndarray) -> np.ndarray:
    """(F, J) radians: ``angle(q[f+1], q[f] (q[f-1]^-1 q[f]))``, how far the next rotation lies
    from the constant-velocity prediction through frames ``f-1`` and ``f`` (0 on the edges)."""
    q = np.asarray(rotations, dtype=np.float64)
    out = np.zeros(q.shape[:2])
    if q.shape[0] < 3:
        return out
    step = rot.quat_mul(rot.quat_inv(q[:-2]), q[1:-1])
    pred = rot.quat_mul(q[1:-1], step)
    out[1:-1] = rot.quat_angle(q[2:], pred)
    return out


def jump_ratio(rotations: np.ndarray, floor: float, size: int = 3) -> np.ndarray:
    """(F, J) the angular acceleration (median over ``size`` frames, so a lasting jitter counts
    more than one kink) over the joint's median acceleration in the take (at least ``floor``,
    radians)."""
    raw = angular_acceleration(rotations)
    if raw.shape[0] == 0:
        return raw
    a = ndimage.median_filter(raw, size=(size, 1), mode="nearest") if size > 1 else raw
    s = np.maximum(np.median(raw, axis=0), floor)
    return a / s[None, :]


def frozen_cells(
    rotations: np.ndarray,
    digression: np.ndarray,
    min_frames: int,
    speed: float = np.radians(0.01),
    min_digression: float = np.radians(3.0),
    tol: float = np.radians(0.5),
    max_recur: int = 3,
    margin: int = 3,
    exact_share: float = 0.05,
) -> np.ndarray:
    """(F, J) bool: runs of at least ``min_frames`` frames where a joint holds its rotation
    (frame-to-frame angle below ``speed``) while the KNN words move away from it (digression
    above ``min_digression`` somewhere in the run), and the held value is not held elsewhere in
    the take (fewer than ``max_recur`` frames within ``tol`` outside the run where the joint is
    still too: a joint parked at its limit, e.g. a straight elbow or flat toes, comes back to
    rest at the same value again and again; a frozen marker holds an arbitrary one, which the
    joint may pass through but does not rest at; the run and ``margin`` frames around it do not
    count). A hold repeating its value bit for bit (a dropout: marker noise moves a live joint
    by more than a file's last digit every frame) is frozen even where the KNN words hold too,
    and is a park only where that exact value recurs (a solver clamping the joint at its limit
    writes the same value each time): toes frozen flat through a toe-off, at a value they rest
    near between steps, are frozen. Such a hold is judged apart from the slowly turning frames
    beside it (:func:`held_runs`), on joints whose data do not repeat values all along
    (:func:`exact_holds_tell`, ``exact_share``)."""
    q = np.asarray(rotations, dtype=np.float64)
    F, J = q.shape[:2]
    out = np.zeros((F, J), dtype=bool)
    if F < 2:
        return out
    still = rot.quat_angle(q[:-1], q[1:]) < speed  # (F-1, J): frame f -> f+1
    for j in range(J):
        tell = exact_holds_tell(q[:, j], min_frames, exact_share)
        for a, b in held_runs(q[:, j], still[:, j], min_frames, tell):
            verdict = frozen_verdict(
                q[:, j], still[:, j], digression[:, j], a, b, min_frames, min_digression, tol,
                max_recur, margin, tell,
            )  # fmt: skip
            if verdict[0] == "frozen":
                out[held_from(a) : b + 2, j] = True
    return out


def held_from(a: int) -> int:
    """The first frame a frozen run of still steps ``a ..`` (step f: frame f -> f+1) flags: the
    run's first frame holds the last value captured (the one repeated after it), genuine, unless
    the take opens with the hold (frame 0: no capture before it)."""
    return a + 1 if a > 0 else 0


def exact_holds_tell(q: np.ndarray, min_frames: int, max_share: float) -> bool:
    """Whether an exact hold of one joint's rotations ``q`` (F, 4) tells a dropout. A captured
    joint repeats a value bit for bit only where the solver had no data (runs of many frames);
    a joint whose steps repeat exactly in shorter runs (under ``min_frames`` steps) on more than
    ``max_share`` of its steps has data that repeat values all along (a lower-rate source
    written at a higher rate, a VR or keyframed rig), and exactness tells nothing there."""
    exact = np.all(q[1:] == q[:-1], axis=-1)
    short = sum(b - a + 1 for a, b in true_runs(exact) if b - a + 1 < min_frames)
    return short <= max_share * max(len(exact), 1)


def held_runs(
    q: np.ndarray, still: np.ndarray, min_frames: int, split: bool = True
) -> list[tuple[int, int]]:
    """The runs ``(a, b)`` (steps, inclusive) of ``still`` (F-1,) of one joint's rotations ``q``
    (F, 4), each exact hold in them (steps repeating the value bit for bit) of at least
    ``min_frames`` steps split out as a run of its own (unless not ``split``: see
    :func:`exact_holds_tell`): a dropout that begins or ends while the joint turns slowly is
    judged apart from the live frames beside it."""
    if not split:
        return true_runs(still)
    exact = np.all(q[1:] == q[:-1], axis=-1)
    out = []
    for a, b in true_runs(still):
        pos = a
        for x, y in true_runs(exact[a : b + 1]):
            if y - x + 1 < min_frames:
                continue
            if x + a > pos:
                out.append((pos, x + a - 1))
            out.append((x + a, y + a))
            pos = y + a + 1
        if pos <= b:
            out.append((pos, b))
    return out


def frozen_verdict(
    q: np.ndarray,
    still: np.ndarray,
    digression: np.ndarray,
    a: int,
    b: int,
    min_frames: int,
    min_digression: float,
    tol: float,
    max_recur: int,
    margin: int,
    exact_counts: bool = True,
) -> tuple[str, float]:
    """:func:`frozen_cells`' verdict on one joint's still run ``a .. b`` (steps f -> f+1; ``q``
    (F, 4), ``still`` (F-1,), ``digression`` (F,)): ``("short", 0)``, ``("calm", peak
    digression)`` (the KNN words do not move away), ``("rests", frames held at that value
    elsewhere)`` or ``("frozen", peak digression)``. ``exact_counts``: whether a hold repeating
    its value bit for bit is told apart (:func:`exact_holds_tell`): such a hold, between two
    frames that are not held, is a dropout even where the KNN words hold too (a natural pause
    is never exact), and a park only at a value that recurs exactly."""
    if b - a + 1 < min_frames:
        return "short", 0.0
    dig = float(digression[a : b + 2].max())
    # a dropout comes back: a hold reaching the take's first or last frame (a joint the take
    # never captured, or data that start or end late) is judged as any still run
    inside = a > 0 and b + 2 < len(q)
    exact = exact_counts and inside and bool(np.all(q[a : b + 2] == q[a]))
    if dig <= min_digression and not exact:  # a pause; but a pause is never exact
        return "calm", dig
    # repeated bit for bit: a solver clamping a joint at its limit writes that same value each
    # time it parks there, while a natural rest near it is never exact; so only an exact
    # recurrence makes an exact hold a park (a dropout repeats one value, once)
    near = np.all(q == q[a][None], axis=-1) if exact else rot.quat_angle(q, q[a][None]) < tol
    near[:-1] &= still  # at rest there, not passing through
    near[-1] &= still[-1]
    near[max(a - margin, 0) : b + margin + 2] = False
    recur = int(near.sum())
    return ("rests", float(recur)) if recur >= max_recur else ("frozen", dig)


def limit_values(
    q: np.ndarray, still: np.ndarray, min_frames: int, min_holds: int, tol: float
) -> np.ndarray:
    """(L, 4) the rotations one joint (``q`` (F, 4), ``still`` (F-1,) its held steps) comes to
    rest at again and again: the first value of each still run of at least ``min_frames``
    frames that at least ``min_holds`` such runs (itself included) rest within ``tol`` radians
    of. A solver clamping a joint at its limit (toes flat at -16.6 deg in Bandai-1's
    dance-short takes) writes the limit's value each time it parks the joint there; a natural
    pause rests somewhere new each time."""
    runs = [(a, b) for a, b in true_runs(still) if b - a + 2 >= min_frames]
    if len(runs) < max(min_holds, 1):
        return np.zeros((0, 4))
    v = np.asarray([q[a] for a, _ in runs], dtype=np.float64)
    near = rot.quat_angle(v[:, None], v[None, :]) <= tol  # (R, R)
    out, taken = [], np.zeros(len(v), dtype=bool)
    for i in np.argsort(-near.sum(axis=1), kind="stable"):
        if not taken[i] and near[i].sum() >= min_holds:
            out.append(v[i])
            taken |= near[i]
    return np.asarray(out).reshape(-1, 4)


def limit_excursions(
    q: np.ndarray, still: np.ndarray, min_frames: int, min_holds: int, tol: float
) -> list[tuple[int, int]]:
    """The excursions ``(s, e)`` (frames, inclusive) of one joint off a limit it is clamped at
    (:func:`limit_values`): runs of at least two frames farther than ``tol`` from it, with
    frames at the limit on both sides."""
    lims = limit_values(q, still, min_frames, min_holds, tol)
    if not len(lims):
        return []
    at = (rot.quat_angle(q[:, None], lims[None]) <= tol).any(axis=1)
    return [(int(s), int(e)) for s, e in true_runs(~at) if 0 < s < e < len(q) - 1]


def hysteresis(weak: np.ndarray, strong: np.ndarray) -> np.ndarray:
    """(F, J) bool: the runs (along time, per joint) of ``weak | strong`` cells that hold at
    least one ``strong`` cell."""
    m = np.asarray(weak, dtype=bool) | np.asarray(strong, dtype=bool)
    structure = np.array([[0, 1, 0], [0, 1, 0], [0, 1, 0]], dtype=bool)
    lab, _ = ndimage.label(m, structure=structure)
    ids = np.unique(lab[np.asarray(strong, dtype=bool)])
    ids = ids[ids > 0]
    return np.isin(lab, ids)


def dominated_runs(
    mask: np.ndarray, z: np.ndarray, keep: np.ndarray, ratio: float, pad: int
) -> np.ndarray:
    """(F, J) bool: the runs of ``mask`` (per joint) that hold no ``keep`` cell and whose peak
    ``z`` stays below ``ratio`` times the peak of another joint within ``pad`` frames of the
    run. A gross error on one joint bends the time-warped neighbours of every word around it,
    which raises the digression of the other joints there too."""
    out = np.zeros_like(mask, dtype=bool)
    J = mask.shape[1]
    if ratio <= 0 or J < 2:
        return out
    for j in range(J):
        for a, b in true_runs(mask[:, j]):
            if keep[a : b + 1, j].any():
                continue
            win = np.delete(z[max(a - pad, 0) : b + 1 + pad], j, axis=1)
            if z[a : b + 1, j].max() < ratio * win.max():
                out[a : b + 1, j] = True
    return out


# A capture error starts and ends with a *step*: one frame-to-frame rotation far from the steps
# around it (a velocity outlier), while fast natural motion changes its velocity smoothly. The
# error lies between an entry step and an exit step on the same joint, on the side of each step
# where the joint digresses from its KNN words.


def _body_steps(q: np.ndarray) -> np.ndarray:
    """(F - 1, J, 3) rotation vectors of the body-frame steps ``log(q[i]^-1 q[i+1])``."""
    return rot.quat_to_rotvec(rot.quat_mul(rot.quat_inv(q[:-1]), q[1:]))


def frame_steps(q: np.ndarray, frame: str = "body") -> np.ndarray:
    """(F - 1, ..., 3) rotation vectors of the steps from frame ``i`` to ``i + 1`` of the
    rotations ``q`` (F, ..., 4): ``log(q[i]^-1 q[i+1])`` in the joint's own (``"body"``) frame
    or ``log(q[i+1] q[i]^-1)`` in its parent's (``"parent"``)."""
    if frame == "body":
        return _body_steps(q)
    if frame == "parent":
        return rot.quat_to_rotvec(rot.quat_mul(q[1:], rot.quat_inv(q[:-1])))
    raise ValueError(f"frame must be 'body' or 'parent', got {frame!r}")


def step_deviations(rotations: np.ndarray, frame: str = "body") -> np.ndarray:
    """(F, J, 3) radians: ``v[f] = w[f-1] - (w[f-2] + w[f]) / 2`` with ``w[i]`` the rotation
    vector of the step from frame ``i`` to ``i + 1``, ``log(q[i]^-1 q[i+1])`` in the joint's own
    (``"body"``) frame or ``log(q[i+1] q[i]^-1)`` in its parent's (``"parent"``): how far the
    step into frame ``f`` lies from the mean of its neighbouring steps (0 where undefined,
    ``f < 2`` or ``f > F - 2``). A rotation ``d`` applied to frames ``a .. b - 1`` on the body
    side (``q d``) gives ``v[a] ~ log d`` and ``v[b] ~ -log d``; on the parent side (``d q``), the
    same in the parent frame."""
    q = np.asarray(rotations, dtype=np.float64)
    out = np.zeros((*q.shape[:2], 3))
    if q.shape[0] < 4:
        return out
    w = frame_steps(q, frame)
    out[2:-1] = w[1:-1] - 0.5 * (w[:-2] + w[2:])
    return out


def step_size(rotations: np.ndarray) -> np.ndarray:
    """(F, J) radians: the length of :func:`step_deviations` (body frame), how far the step into
    frame ``f`` lies from the mean of its neighbouring steps. A jump of angle ``a`` into frame
    ``f`` gives ``a`` at ``f`` and ``a / 2`` at ``f ± 1``."""
    return np.linalg.norm(step_deviations(rotations), axis=-1)


def jump_size(rotations: np.ndarray) -> np.ndarray:
    """(F, J) radians: ``min(|w[f-1] - w[f-2]|, |w[f-1] - w[f]|)`` with ``w[i]`` the rotation
    vector of the body-frame step from frame ``i`` to ``i + 1``: how much the step into frame
    ``f`` differs from *both* its neighbours. A jump in position (a pose displaced from frame
    ``f`` on) gives its angle; a kink in velocity (a limb starting or stopping at once) changes
    the step on one side only and gives ~0 (0 where undefined, ``f < 2`` or ``f > F - 2``)."""
    q = np.asarray(rotations, dtype=np.float64)
    out = np.zeros(q.shape[:2])
    if q.shape[0] < 4:
        return out
    w = _body_steps(q)
    before = np.linalg.norm(w[1:-1] - w[:-2], axis=-1)
    after = np.linalg.norm(w[1:-1] - w[2:], axis=-1)
    out[2:-1] = np.minimum(before, after)
    return out


def still_jumps(rotations: np.ndarray, min_step: float, ratio: float, width: int) -> np.ndarray:
    """(F, J) bool, indexed as :func:`jump_size`: frames ``f`` entered by a step (``|w[f-1]|``,
    the body-frame rotation from frame ``f - 1`` to ``f``) over ``min_step`` radians and over
    ``ratio`` times every step of the ``width`` frames before and after it (at least one each
    side), and whose jump (:func:`jump_size`) is over ``min_step`` too: the joint is still,
    turns at once, and is still again. A joint at rest seldom turns by several degrees within
    one frame and stops dead (a foot strike stops a moving toe; it does not move a still one;
    a dancer's toe snap does, and is left to the pairing), so a still joint's jump is a
    candidate error edge however small it is against the joint's ordinary jumps. "Still" is
    per frame: at 120 fps the steps around may be four times as fast in degrees per second
    as at 30 fps."""
    q = np.asarray(rotations, dtype=np.float64)
    F = q.shape[0]
    out = np.zeros(q.shape[:2], dtype=bool)
    if F < 4 or width < 1 or ratio <= 0:
        return out
    s = np.linalg.norm(_body_steps(q), axis=-1)  # (F-1, J): s[i] from frame i to i + 1
    n = s.shape[0]
    pad = np.pad(s, ((width, width), (0, 0)), constant_values=-1.0)
    near = np.full(s.shape, -1.0)
    for k in range(1, width + 1):
        before, after = pad[width - k : width - k + n], pad[width + k : width + k + n]
        near = np.maximum(near, np.maximum(before, after))
    still = (s > min_step) & (s > ratio * near)
    out[1:] = still
    # as a jump peak: the jump itself over min_step too; jump_size is 0 on frames f < 2 and
    # f > F - 2, where a step has no neighbour on one side
    out &= jump_size(q) > min_step
    return out


def step_peaks(
    steps: np.ndarray, ratio: float, min_step: float, quantile: float = 99.0
) -> np.ndarray:
    """(F, J) bool: local maxima (along time) of :func:`step_size` above ``ratio`` times the
    joint's ``quantile`` of steps in the take and above ``min_step`` radians (feet hit the
    ground with natural steps, so each joint is judged against its own). In a take of a few
    seconds, an error's own steps make up the top percent: then nothing passes, and detection
    rests on the other seeds."""
    s = np.asarray(steps, dtype=np.float64)
    if s.shape[0] == 0:
        return np.zeros(s.shape, dtype=bool)
    scale = np.percentile(s, quantile, axis=0)
    pad = np.full((1, s.shape[1]), -1.0)
    left = np.vstack([pad, s[:-1]])
    right = np.vstack([s[1:], pad])
    return (s > ratio * scale[None, :]) & (s > min_step) & (s >= left) & (s > right)


def step_sides(peaks: np.ndarray, z: np.ndarray, width: int) -> np.ndarray:
    """(F, J) int8 at the ``peaks``: +1 when the error lies after the step (the normalised
    digression ``z`` is higher over the ``width`` frames from the peak on than over the
    ``width`` frames before it: an entry), -1 when before (an exit), 0 elsewhere."""
    out = np.zeros(peaks.shape, dtype=np.int8)
    for f, j in zip(*np.nonzero(peaks), strict=True):
        after = z[f : f + width, j].mean()
        before = z[max(0, f - width) : f, j].mean() if f > 0 else -np.inf
        out[f, j] = 1 if after >= before else -1
    return out


def step_cells(peaks: np.ndarray, sides: np.ndarray) -> np.ndarray:
    """(F, J) bool: for each step peak the cell on its erroneous side (the peak's own frame for
    an entry, the frame before it for an exit)."""
    out = np.zeros(peaks.shape, dtype=bool)
    f, j = np.nonzero(peaks & (sides > 0))
    out[f, j] = True
    f, j = np.nonzero(peaks & (sides < 0))
    keep = f > 0
    out[f[keep] - 1, j[keep]] = True
    return out


def cancelling_steps(
    peaks: np.ndarray,
    deviations: Sequence[np.ndarray],
    max_frames: int,
    tol: float,
    sides: np.ndarray | None = None,
    sided_frames: int = 0,
    used_out: np.ndarray | None = None,
    pops: np.ndarray | None = None,
    axis_cos: float = 0.0,
    axis_peaks: np.ndarray | None = None,
) -> np.ndarray:
    """(F, J) bool: the frames ``a .. e - 1`` between two ``peaks`` of a joint (``e - a``
    at most ``max_frames``) whose deviations cancel, ``|v[a] + v[e]| < tol * min(|v[a]|,
    |v[e]|)`` in one of the frames of ``deviations`` (each (F, J, 3), :func:`step_deviations`):
    a stretch turned by one constant rotation, entered and left with opposite steps (a spike,
    an offset, a flip). Natural motion that jumps seldom jumps back by the same rotation; take
    the peaks of :func:`jump_size`, as a limb that starts and stops at once (a kick from rest
    back to rest) kinks its velocity with opposite deviations too.

    A turn of about 180 deg has two rotation vectors of nearly the same length pointing
    opposite ways (``log`` reports the one under 180 deg), so the exit of a flip may come out
    pointing the same way as its entry: the exit's other representation
    (:func:`_other_side`) is tried too.

    Each peak pairs at most once, the best-cancelling pairs first: two errors close together
    on one joint (the entry of the first, its exit, the entry of the second, ...) pair as two
    stretches, not through the exit of the first and the entry of the second across the clean
    frames between them. With ``sides`` (:func:`step_sides` of the peaks: +1 the error lies
    after the jump, -1 before), a jump that leaves an error is not paired with a later one
    that enters an error, ``sided_frames`` or more frames on: two wrong-way bends of an elbow
    are not constant turns, so their own ends cancel poorly, and the exit of the first
    cancelled the entry of the second better (Bandai-1 tuning half, gestures, bends: precision
    0.929 / 0.975 local, 0.951 / 1.000 small context, without / with). Closer than a source
    word the words' digression blurs the two sides, and a short spike's ends were misjudged
    (a first version without ``sided_frames`` lost spike recall on the validation half).
    The refusal holds only where the pair is flanked (:func:`_flanked`): an entry within
    ``max_frames`` before it, or the take's start (an error cut off there), and an exit or
    the take's end within ``max_frames`` after it. Two bends bring their own outer ends; a
    lone error whose words match the turned stretch has its sides misread (the digression is
    lower inside than around it) and nothing flanks it (tuning half, seeds 0-6: dance/fight
    offset recall 0.972 -> 0.989 local, 0.982 -> 0.995 small, bend precision unchanged;
    validation half, seeds 0-2: no figure changed).

    ``pops`` ((F, J) bool, optional: :func:`one_frame_spikes` of the peaks): a peak whose own
    neighbour frame's deviation cancels it is one side of a one-frame pop: its other side is
    that neighbour, which :func:`jump_size`'s local maxima leave out, so it pairs with no
    farther peak (the spike rule judges it). A natural toe pop at foot strike, one frame each
    step, otherwise paired the exit of one pop with the entry of the next across the stance
    between (Bandai-1 validation half, walk-back_angry's toes, session 26). None: none.

    ``axis_cos`` and ``axis_peaks`` ((F, J) bool, the peaks large enough; with ``axis_cos`` >
    0): two such peaks that do not cancel pair too where their deviations point opposite ways,
    ``-v[a] . v[e] > axis_cos |v[a]| |v[e]|`` in one of the frames: a stretch turned about one
    axis by an angle that changes over it (a wrong-way bend mirrors the flexion, so its turn
    grows and shrinks with the joint's own), entered and left about that axis by jumps of
    different sizes. They pair after every cancelling pair. A turn that passes 180 deg inside
    the stretch is left by a jump pointing the way it entered (:func:`_opposed`, ``flip``):
    that reading is tried only for two peaks next to each other (none of the joint's between)
    whose ``sides`` read an entry then an exit (never without them).

    Two turned stretches of one joint nest or lie apart; a pair that interleaves a kept one
    (one jump inside its stretch, the other outside) with jumps under half as large is a
    natural pair across the larger stretch's edge, and is dropped: a dancer's elbow paired two
    of its own 1-deg step deviations across the entry of a 40-deg twist, and the flagged run
    began three frames before the twist, so the turn-back read its turn there (newcomer).

    ``used_out`` ((F, J) bool, optional) receives the peaks that paired (a one-frame spike's
    with its neighbour)."""
    out = np.zeros(peaks.shape, dtype=bool)
    F = peaks.shape[0]
    spikes = np.zeros(peaks.shape, dtype=bool) if pops is None else np.asarray(pops, bool)
    for j in np.flatnonzero(np.asarray(peaks).any(axis=0)):
        ps = np.flatnonzero(peaks[:, j] & ~spikes[:, j])
        pairs = []
        for i, a in enumerate(ps):
            for e in ps[i + 1 :]:
                if e - a > max_frames:
                    break
                if (
                    sides is not None
                    and e - a >= sided_frames
                    and sides[a, j] < 0
                    and sides[e, j] > 0
                    and _flanked(ps, sides[:, j], a, e, max_frames, F)
                ):
                    continue  # leaves an error, then enters another: clean frames between
                ratio = min(
                    np.linalg.norm(v[a, j] + x)
                    / max(min(np.linalg.norm(v[a, j]), np.linalg.norm(v[e, j])), 1e-12)
                    for v in deviations
                    for x in (v[e, j], _other_side(v[e, j]))
                )
                if ratio < tol:
                    pairs.append((ratio, a, e))
                elif axis_cos > 0 and axis_peaks is not None and axis_peaks[[a, e], j].all():
                    # a turn that passed 180 deg inside the stretch leaves it pointing the way it
                    # entered: read so only between an entry and an exit next to each other (with
                    # it, any two jumps about one axis oppose, so their order must tell)
                    flip = sides is not None and sides[a, j] > 0 > sides[e, j] and e == ps[i + 1]
                    c = _opposed(deviations, a, e, j, flip)
                    if c > axis_cos:
                        pairs.append((tol + 1.0 - c, a, e))
        taken: set[int] = set()
        kept: list[tuple[int, int, float]] = []
        for _, a, e in sorted(pairs):
            if a not in taken and e not in taken:
                taken.update((a, e))
                kept.append((a, e, _pair_size(deviations, a, e, j)))
        used: set[int] = set()
        for a, e, size in kept:
            if any(
                (a < a2 < e < e2 or a2 < a < e2 < e) and size < 0.5 * size2
                for a2, e2, size2 in kept
            ):
                continue  # a pair of small jumps across the edge of a larger turned stretch
            used.update((a, e))
            out[a:e, j] = True
        if used_out is not None:
            used_out[sorted(used), j] = True
    if used_out is not None:
        used_out |= spikes & peaks  # paired with the frame beside them
    return out


def _pair_size(deviations: Sequence[np.ndarray], a: int, e: int, j: int) -> float:
    """The smaller of the two step deviations of a pair (the largest over the frames of
    ``deviations``): how far the pair's stretch was turned."""
    return max(min(np.linalg.norm(v[a, j]), np.linalg.norm(v[e, j])) for v in deviations)


def _opposed(deviations: Sequence[np.ndarray], a: int, e: int, j: int, flip: bool = False) -> float:
    """The largest cosine between ``-v[a, j]`` and ``v[e, j]`` over the frames of
    ``deviations``. ``flip``: also with the larger of the two read the other way round
    (:func:`_other_side`, which points the opposite way) where it turns over 90 deg
    (:data:`FLIP_MIN_DEG`): a stretch whose turn passes 180 deg between its ends (a wrong-way
    elbow bent 40 deg at the entry and 229 deg, read as 131 deg the other way, at the exit;
    Bandai-1 tuning half, gestures) is left about its axis by a jump pointing the way it was
    entered."""
    best = -1.0
    for v in deviations:
        x, y = v[a, j], v[e, j]
        nx, ny = float(np.linalg.norm(x)), float(np.linalg.norm(y))
        if nx * ny > 0:
            c = -float(x @ y) / (nx * ny)
            best = max(best, c)
            if flip and max(nx, ny) > np.radians(FLIP_MIN_DEG):
                best = max(best, -c)
    return best


FLIP_MIN_DEG = 90.0
"""A jump turning further than this may be read the other way round by :func:`_opposed`: its
other representation then turns under 270 deg, which a wrong-way bend of a knee or elbow (its
flexion mirrored, twice the flexion plus a little) reaches."""


def one_frame_spikes(peaks: np.ndarray, deviations: Sequence[np.ndarray], tol: float) -> np.ndarray:
    """(F, J) bool: the ``peaks`` whose step deviation is cancelled by the one of a frame beside
    them (:func:`pop_partner`)."""
    peaks = np.asarray(peaks, dtype=bool)
    out = np.zeros(peaks.shape, dtype=bool)
    for f, j in zip(*np.nonzero(peaks), strict=True):
        out[f, j] = pop_partner(deviations, int(f), int(j), tol) is not None
    return out


def pop_partner(deviations: Sequence[np.ndarray], f: int, j: int, tol: float) -> int | None:
    """The frame beside ``f`` (``f - 1`` or ``f + 1``) whose step deviation cancels joint
    ``j``'s at ``f``, ``|v[f] + v[g]| < tol * min(|v[f]|, |v[g]|)`` in one of ``deviations``'
    frames (:func:`step_deviations`), or None. A frame displaced by ``d`` alone gives ``v =
    1.5 d`` into it and ``-1.5 d`` out of it (ratio 0): the two sides of a one-frame pop; the
    entry of a longer stretch gives ``d`` with ``-d/2`` on either side (ratio 1), or 0 inside
    a stretch of two frames."""
    if not deviations:
        return None
    F = deviations[0].shape[0]
    for g in (f - 1, f + 1):
        if not 0 <= g < F:
            continue
        for v in deviations:
            a, b = v[f, j], v[g, j]
            small = min(np.linalg.norm(a), np.linalg.norm(b))
            if small > 0 and np.linalg.norm(a + b) < tol * small:
                return g
    return None


def _flanked(
    peaks: np.ndarray, sides: np.ndarray, a: int, e: int, max_frames: int, num_frames: int
) -> bool:
    """Whether an entry peak lies within ``max_frames`` before ``a`` (or the take's start
    does: an error cut off by it has no entry) and an exit peak within ``max_frames`` after
    ``e`` (or the take's end does). ``peaks``: one joint's peak frames, ``sides`` its sides."""
    before = a - max_frames < 0 or any(sides[p] > 0 for p in peaks if a - max_frames <= p < a)
    after = e + max_frames > num_frames - 1 or any(
        sides[q] < 0 for q in peaks if e < q <= e + max_frames
    )
    return before and after


def cut_off_steps(
    peaks: np.ndarray, paired: np.ndarray, sides: np.ndarray, max_frames: int
) -> np.ndarray:
    """(F, J) bool: the stretches an error cut off by the take's end or start may hold. A
    peak of ``peaks`` that did not pair (``paired``, :func:`cancelling_steps`' ``used_out``)
    and enters an error (``sides`` +1) at most ``max_frames`` frames from the take's end, with
    no peak leaving an error after it, marks the frames from it to the last; one that leaves an
    error (-1) at most ``max_frames`` frames into the take, with no peak entering one before
    it, marks the frames before it. Such an error has one jump only, so nothing pairs it."""
    peaks = np.asarray(peaks, dtype=bool)
    F = peaks.shape[0]
    out = np.zeros(peaks.shape, dtype=bool)
    for j in np.flatnonzero(peaks.any(axis=0)):
        ps = np.flatnonzero(peaks[:, j])
        for p in ps[~paired[ps, j]]:
            later, earlier = ps[ps > p], ps[ps < p]
            if sides[p, j] > 0 and F - p <= max_frames and not (sides[later, j] < 0).any():
                out[p:, j] = True
            elif sides[p, j] < 0 and p <= max_frames and not (sides[earlier, j] > 0).any():
                out[:p, j] = True
    return out


def _other_side(v: np.ndarray) -> np.ndarray:
    """The same turn as rotation vector ``v`` the other way round: ``v - 2 pi v / |v|`` (angle
    ``2 pi - |v|``); for a turn near 180 deg about as long as ``v`` itself."""
    n = np.linalg.norm(v)
    return v - (2.0 * np.pi / n) * v if n > 0 else v


def spike_size(rotations: np.ndarray, max_frames: int, floor: float = 0.0) -> np.ndarray:
    """(F, J) radians: how far a short stretch holding the frame leaves the joint's own smooth
    path. For every gap of ``1 .. max_frames`` frames, the cubic through the two frames before
    and the two after it (in the tangent space at the frame before) predicts the gap; the gap's
    score is its *smallest* angle from the prediction (the whole gap is off, not one frame of
    natural motion), and a frame takes the largest score of the gaps holding it (0 where no gap
    with two frames either side fits).

    ``floor`` (radians): values at or below it are only bounded (a gap whose first frame lies
    within ``floor`` of the prediction is not scored further; its frames get at most ``floor``):
    exact above the floor. A compiled loop (:func:`_spike_kernel`; the reference is
    ``tests/clean/naive.py``): the vectorised version spent 0.2 s per 15 s take at 120 fps,
    four times the rest of the rules."""
    q = np.asarray(rotations, dtype=np.float64)
    if q.ndim != 3 or q.shape[2] != 4:
        raise ValueError(f"rotations must be (F, J, 4), got {q.shape}")
    if not np.isfinite(q).all():
        raise ValueError("rotations must be finite")
    norms = np.linalg.norm(q, axis=-1, keepdims=True)
    if (norms == 0).any():
        raise ValueError("rotations must be unit quaternions (a zero one was given)")
    q = q / norms
    out = np.zeros(q.shape[:2])
    longest = min(int(max_frames), q.shape[0] - 4)  # a gap needs two frames on either side
    if longest >= 1:
        _spike_kernel(np.ascontiguousarray(q), longest, float(floor), out)
    return out


def end_spike_size(rotations: np.ndarray) -> np.ndarray:
    """(F, J) radians: how far a take's first and last frames lie from the joint's constant
    turn through the frames beside them, 0 on every other frame and on takes under 5 frames.
    :func:`spike_size` cannot score them (its cubic needs two frames either side); a joint's
    turn changes per frame by its jump, so a natural end frame lies off by about one ordinary
    jump, and a pop on it by the pop's angle. The turn is read from the frame pairs (1, 2),
    (1, 3), (2, 3) and (3, 4) counted from the end, and the end frame takes the smallest miss:
    a pop on one of those frames (or on two neighbours) spoils some pairs, never all, so it is
    not blamed on the clean end frame beside it."""
    q = np.asarray(rotations, dtype=np.float64)
    out = np.zeros(q.shape[:2])
    F = q.shape[0]
    if F < 5:
        return out
    for end, sign in ((0, 1), (F - 1, -1)):
        best = np.full(q.shape[1], np.inf)
        for i, j in ((1, 2), (1, 3), (2, 3), (3, 4)):
            qi, qj = q[end + sign * i], q[end + sign * j]
            per_frame = rot.quat_to_rotvec(rot.quat_mul(rot.quat_inv(qi), qj)) / (j - i)
            ahead = rot.quat_mul(qi, rot.rotvec_to_quat(-i * per_frame))
            best = np.minimum(best, rot.quat_angle(q[end], ahead))
        out[end] = best
    return out


@numba.njit(cache=True, nogil=True)
def _qmul(a0, a1, a2, a3, b0, b1, b2, b3):  # pragma: no cover - compiled
    return (
        a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3,
        a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
        a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1,
        a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0,
    )


@numba.njit(cache=True, nogil=True)
def _log(w, x, y, z):  # pragma: no cover - compiled
    """Rotation vector of a unit quaternion (shortest rotation), as rot.quat_to_rotvec."""
    if w < 0.0:
        w, x, y, z = -w, -x, -y, -z
    s = np.sqrt(x * x + y * y + z * z)
    angle = 2.0 * np.arctan2(s, w)
    if angle < 1e-4:
        a2 = angle * angle
        k = 2.0 + a2 / 12.0 + 7.0 * a2 * a2 / 2880.0
    else:
        k = angle / s
    return x * k, y * k, z * k


@numba.njit(cache=True, nogil=True)
def _exp(x, y, z):  # pragma: no cover - compiled
    """Unit quaternion of a rotation vector, as rot.rotvec_to_quat."""
    angle = np.sqrt(x * x + y * y + z * z)
    if angle < 1e-4:
        a2 = angle * angle
        k = 0.5 - a2 / 48.0 + a2 * a2 / 3840.0
    else:
        k = np.sin(0.5 * angle) / angle
    return np.cos(0.5 * angle), x * k, y * k, z * k


@numba.njit(cache=True, nogil=True)
def _log_from(r0, r1, r2, r3, b):  # pragma: no cover - compiled
    """Rotation vector of ``b`` (4,) relative to the unit quaternion ``r``: log(r^-1 b)."""
    w, x, y, z = _qmul(r0, -r1, -r2, -r3, b[0], b[1], b[2], b[3])
    return _log(w, x, y, z)


@numba.njit(cache=True, nogil=True, parallel=True)
def _spike_kernel(q, max_frames, floor, out):  # pragma: no cover - compiled
    F, J = q.shape[0], q.shape[1]
    # Lagrange weights of the cubic through the knots -2, -1, n, n + 1 at the gap's frames
    W = np.zeros((max_frames + 1, max_frames, 4))
    for n in range(1, max_frames + 1):
        knots = np.array([-2.0, -1.0, float(n), n + 1.0])
        for g in range(n):
            for k in range(4):
                v = 1.0
                for m in range(4):
                    if m != k:
                        v *= (g - knots[m]) / (knots[k] - knots[m])
                W[n, g, k] = v
    for j in numba.prange(J):  # joints are independent: one per thread
        logs = np.empty((max_frames + 3, 3))  # log(q[a-1]^-1 q[a-1+d]), d = 2 .. max + 2
        for a in range(2, F - 2):
            r0, r1, r2, r3 = q[a - 1, j, 0], q[a - 1, j, 1], q[a - 1, j, 2], q[a - 1, j, 3]
            x0 = _log_from(r0, r1, r2, r3, q[a - 2, j])
            top = min(max_frames, F - a - 2)  # the longest gap with two frames after it
            for d in range(2, top + 3):
                x = _log_from(r0, r1, r2, r3, q[a - 1 + d, j])
                logs[d, 0], logs[d, 1], logs[d, 2] = x[0], x[1], x[2]
            for n in range(1, top + 1):
                score = np.inf
                for g in range(n):  # the knot at -1 is the reference itself: log 0
                    w0, w2, w3 = W[n, g, 0], W[n, g, 2], W[n, g, 3]
                    tx = w0 * x0[0] + w2 * logs[n + 1, 0] + w3 * logs[n + 2, 0]
                    ty = w0 * x0[1] + w2 * logs[n + 1, 1] + w3 * logs[n + 2, 1]
                    tz = w0 * x0[2] + w2 * logs[n + 1, 2] + w3 * logs[n + 2, 2]
                    e0, e1, e2, e3 = _exp(tx, ty, tz)
                    p = _qmul(r0, r1, r2, r3, e0, e1, e2, e3)
                    c = q[a + g, j]
                    rel = _qmul(p[0], -p[1], -p[2], -p[3], c[0], c[1], c[2], c[3])
                    s = np.sqrt(rel[1] * rel[1] + rel[2] * rel[2] + rel[3] * rel[3])
                    ang = 2.0 * np.arctan2(s, abs(rel[0]))
                    if ang < score:
                        score = ang
                    if g == 0 and score <= floor:
                        break  # the first frame is on the path: bounded, not scored further
                for g in range(n):
                    if score > out[a + g, j]:
                        out[a + g, j] = score


# Two signal-level seeds that need no KNN word: a noise burst shakes the joint frame to frame
# (the KNN words of a weakly jittered fast joint may agree with it), and a knee or elbow bent
# the wrong way is impossible whatever the context holds (and a take with several such bends
# on one joint matches them with each other).


def burst_roughness(rotations: np.ndarray) -> np.ndarray:
    """(F, J) radians: ``|w[f-1] - 2 w[f] + w[f+1]|`` with ``w[i]`` the rotation vector of the
    body-frame step from frame ``i`` to ``i + 1``: the second difference of the angular
    velocity, which spans frames ``f - 1 .. f + 2`` (0 where undefined, ``f < 1`` or
    ``f > F - 3``). Smooth motion keeps it small (it grows with the cube of the frequency);
    white noise of ``s`` radians per axis gives about ``4.5 s`` per axis."""
    q = np.asarray(rotations, dtype=np.float64)
    F = q.shape[0]
    out = np.zeros(q.shape[:2])
    if F < 4:
        return out
    w = _body_steps(q)
    out[1 : F - 2] = np.linalg.norm(w[:-2] - 2.0 * w[1:-1] + w[2:], axis=-1)
    return out


def turn_change(rotations: np.ndarray) -> np.ndarray:
    """(F, J) radians: ``|w[f] - w[f-1]|`` with ``w[i]`` the rotation vector of the body-frame
    step from frame ``i`` to ``i + 1``: how much the step out of frame ``f`` differs from the
    step into it (0 where undefined, ``f < 1`` or ``f > F - 2``)."""
    q = np.asarray(rotations, dtype=np.float64)
    out = np.zeros(q.shape[:2])
    if q.shape[0] < 3:
        return out
    w = _body_steps(q)
    out[1 : q.shape[0] - 1] = np.linalg.norm(w[1:] - w[:-1], axis=-1)
    return out


def noise_bursts(
    roughness: np.ndarray,
    change: np.ndarray,
    min_step: float,
    min_frames: int,
    edge_share: float = 0.15,
    edge_jump: float = 2.0,
    hold_ratio: float = 1.0,
) -> np.ndarray:
    """(F, J) bool: runs of at least ``min_frames`` frames of :func:`burst_roughness` above
    ``min_step`` radians (one-frame gaps filled), mapped back to the burst's frames. An error's
    edge or a limb stopping at once raises the roughness for a few frames only.

    A burst on frames ``a .. b`` raises the roughness on ``a - 2 .. b + 1``, but its outermost
    frames ``a - 2`` and ``b + 1`` see one noisy step only, so they often stay under the
    threshold: a run starts two frames before its burst or one. Which, the step out of its
    first frame ``s`` says (``change``: :func:`turn_change`): one frame before, that step
    enters the burst, so it differs from the step before it by the first frame's noise, more
    than ``edge_share`` of the roughness at ``s`` and more than ``edge_jump`` times the
    change a frame earlier; two frames before, both steps are the clean motion's. Likewise at
    the run's end ``e``: the burst ends at ``e`` when the step out of ``e + 1`` differs from
    the one into it that much, else at ``e - 1``.

    Noise is random, so a few of a burst's frames may deviate little and leave the roughness
    under ``min_step`` for two frames or more, cutting the burst: a run of at least
    ``min_frames`` goes on, either way, over the frames whose roughness stays above
    ``hold_ratio`` times ``min_step`` (one-frame gaps filled; hysteresis)."""
    r = np.asarray(roughness, dtype=np.float64)
    c = np.asarray(change, dtype=np.float64)
    F = r.shape[0]

    def filled(m: np.ndarray) -> np.ndarray:
        out = m.copy()
        out[1:-1] |= m[:-2] & m[2:]
        return out

    def noisy(j: int, f: int, before: int, edge: int) -> bool:
        """Whether the step change at ``f`` carries noise: over ``edge_share`` of the
        roughness at the run's ``edge`` frame and ``edge_jump`` times the change at
        ``before``, a frame further out."""
        if not 0 <= f < F:
            return False
        ref = c[before, j] if 0 <= before < F else 0.0
        return bool(c[f, j] > edge_share * r[edge, j] and c[f, j] > edge_jump * ref)

    strong = filled(r > min_step)
    long = np.zeros(r.shape, dtype=bool)  # the strong runs of at least min_frames frames
    for j in np.flatnonzero(strong.any(axis=0)):
        for a, b in true_runs(strong[:, j]):
            if b - a >= min_frames:
                long[a : b + 1, j] = True
    runs = hysteresis(filled(r > hold_ratio * np.asarray(min_step)), long)
    out = np.zeros(r.shape, dtype=bool)
    for j in np.flatnonzero(runs.any(axis=0)):
        for a, b in true_runs(runs[:, j]):
            first = a + 1 if noisy(j, a, a - 1, a) else a + 2
            last = b if noisy(j, b + 1, b + 2, b) else b - 1
            out[first : last + 1, j] = True
    return out


def axis_share(rotations: np.ndarray, a: int, b: int) -> float:
    """How much of one joint's jerk over frames ``a .. b`` lies along one axis: the largest
    eigenvalue's share of the second moment of its step changes (the differences of
    consecutive body-frame steps, rotation vectors), from 1/3 for a change of turn equally
    likely in every direction to 1 for one about a single axis; NaN under three changes."""
    q = np.asarray(rotations, dtype=np.float64)
    if len(q) < 3:
        return float("nan")
    d = np.diff(_body_steps(q[:, None])[:, 0], axis=0)  # d[k]: the change at frame k + 1
    seg = d[max(a - 1, 0) : max(b, 0)]
    if len(seg) < 3:
        return float("nan")
    ev = np.linalg.svd(seg, compute_uv=False) ** 2
    total = float(ev.sum())
    return float(ev[0] / total) if total > 0 else float("nan")


def wrong_way_bends(
    rotations: np.ndarray,
    hinges: Sequence[int],
    min_angle: float,
    context: Sequence[np.ndarray] = (),
) -> np.ndarray:
    """(F, J) bool: frames where a hinge (knee, elbow; straight at rest) is bent more than
    ``min_angle`` radians past straight the wrong way.

    The flexion axis is the main direction of the joint's rotation vectors (take and
    ``context`` rotations, each (F_i, J, 4)), signed so that the joint spends most of its time
    on the positive side; the flexion is the rotation vector's component on it. A joint whose
    rotations reach 170 deg is skipped (rotation vectors wrap at 180 deg)."""
    q = np.asarray(rotations, dtype=np.float64)
    out = np.zeros(q.shape[:2], dtype=bool)
    for j in hinges:
        own = rot.quat_to_rotvec(q[:, j])
        pool = np.concatenate([own, *(rot.quat_to_rotvec(np.asarray(c)[:, j]) for c in context)])
        if len(pool) == 0 or np.linalg.norm(pool, axis=1).max() > np.radians(170.0):
            continue
        axis = np.linalg.svd(pool, full_matrices=False)[2][0]
        if np.median(pool @ axis) < 0:
            axis = -axis
        out[:, j] = own @ axis < -min_angle
    return out


def extend_to_steps(mask: np.ndarray, steps: np.ndarray, min_step: float, width: int) -> np.ndarray:
    """(F, J) bool: ``mask`` with each run (per joint) stretched back to the latest step (a local
    maximum of ``steps`` above ``min_step`` radians) at most ``width`` frames before it, and on
    to the frame before the earliest step at most ``width + 1`` frames after it: an error's
    first and last frames often digress too little to pass the threshold, its steps bound it."""
    s = np.asarray(steps, dtype=np.float64)
    F = s.shape[0]
    out = np.array(mask, dtype=bool, copy=True)
    if F == 0:
        return out
    pad = np.full((1, s.shape[1]), -1.0)
    peak = (s > min_step) & (s >= np.vstack([pad, s[:-1]])) & (s > np.vstack([s[1:], pad]))
    for j in np.flatnonzero(out.any(axis=0)):
        for a, b in true_runs(mask[:, j]):
            before = np.flatnonzero(peak[max(0, a - width) : a + 1, j])
            if len(before):
                out[max(0, a - width) + before[-1] : a, j] = True
            after = np.flatnonzero(peak[b + 1 : b + 2 + width, j])
            if len(after):
                out[b + 1 : b + 1 + after[0], j] = True
    return out


# Two vetoes on flagged runs, for what a capture error is not:
# - smooth: every error injected or met here (spike, offset, noise, bend, flip) enters or leaves
#   with a step; a run on a joint whose steps stay small around it is natural motion that the
#   context lacks (a dancer's head whip), frozen joints aside;
# - recurring: a short run whose excursion (the joint alone: the poses before, at the peak of
#   and after the run) the joint repeats elsewhere, closer than the KNN words came, is a motif
#   of this performer (toe pops on every push-off), not a random error.


def smooth_runs(
    mask: np.ndarray, steps: np.ndarray, keep: np.ndarray, min_step: float, pad: int
) -> np.ndarray:
    """(F, J) bool: the runs of ``mask`` (per joint) holding no ``keep`` cell whose largest
    :func:`step_size` within ``pad`` frames of the run stays below ``min_step`` radians."""
    out = np.zeros_like(mask, dtype=bool)
    for j in np.flatnonzero(np.asarray(mask).any(axis=0)):
        for a, b in true_runs(mask[:, j]):
            if keep[a : b + 1, j].any():
                continue
            if steps[max(a - pad, 0) : b + 1 + pad, j].max() < min_step:
                out[a : b + 1, j] = True
    return out


def excursion_match(
    track: np.ndarray, start: int, stop: int, others: Sequence[np.ndarray] = (), flex: int = 1
) -> float:
    """Radians: how closely the joint repeats, elsewhere in ``track`` (F, 4) or in a track of
    ``others``, the excursion it makes over frames ``start .. stop - 1``: its three key poses,
    the frame before (entry), the frame of the run farthest from the entry (peak) and the frame
    after (exit), are sought at the same lags give or take ``flex`` frames (a pop may rise in
    one frame or in two); the match is the largest of the three angles, least over all places
    (inf when the run touches the take's ends or nothing fits)."""
    q = np.asarray(track, dtype=np.float64)
    e, x = start - 1, stop
    if e < 0 or x >= len(q):
        return np.inf
    run = q[start:stop]
    p = start + int(np.argmax(rot.quat_angle(run, q[e][None])))
    k, m = p - e, x - e
    best = np.inf
    for idx, t in enumerate((q, *others)):
        t = np.asarray(t, dtype=np.float64)
        n = len(t)
        d_e = rot.quat_angle(t, q[e][None])
        d_p = rot.quat_angle(t, q[p][None])
        d_x = rot.quat_angle(t, q[x][None])
        for kk in range(max(1, k - flex), k + flex + 1):
            for mm in range(max(kk + 1, m - flex), m + flex + 1):
                if mm >= n:
                    continue
                g = np.arange(n - mm)
                cost = np.maximum(d_e[g], np.maximum(d_p[g + kk], d_x[g + mm]))
                if idx == 0:
                    cost[(g <= x) & (g + mm >= e)] = np.inf  # itself, or overlapping it
                if len(cost):
                    best = min(best, float(cost.min()))
    return best


def recurring_runs(
    mask: np.ndarray,
    rotations: np.ndarray,
    digression: np.ndarray,
    max_frames: int,
    max_angle: float,
    ratio: float,
    others: Sequence[np.ndarray] = (),
    flex: int = 1,
) -> np.ndarray:
    """(F, J) bool: the runs of ``mask`` of at most ``max_frames`` frames whose excursion
    (:func:`excursion_match` on ``rotations`` (F, J, 4)) the joint repeats elsewhere in the take
    or in ``others`` (each (F_i, J, 4)) within ``max_angle`` radians, and within ``ratio``
    times the run's peak ``digression``."""
    q = np.asarray(rotations, dtype=np.float64)
    out = np.zeros_like(mask, dtype=bool)
    for j in np.flatnonzero(np.asarray(mask).any(axis=0)):
        for a, b in true_runs(mask[:, j]):
            if b - a + 1 > max_frames:
                continue
            match = excursion_match(q[:, j], a, b + 1, [o[:, j] for o in others], flex)
            if match < max_angle and match < ratio * digression[a : b + 1, j].max():
                out[a : b + 1, j] = True
    return out
