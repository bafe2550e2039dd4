"""Full-skeleton reconstruction from a take holding only some joints (Sec. 4, last part).

The input's words over its known joints are matched (same pose distance and constrained DTW) in a
database of complete takes; among each word's K neighbours, the first word takes the nearest and
every later word the one that best continues the previous choice (word distance plus the pose
distance over the overlapping frames), so that the result is temporally coherent. The chosen
full-body words are blended (triangular weights), brought back to the input's frames, smoothed
with a quadratic Savitzky-Golay filter, and the known joints are copied from the input exactly.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.signal import savgol_filter

from mocapkit import features
from mocapkit.clean.dtw import MAX_RUN, constrained_dtw, pose_distance, pose_distance_matrices
from mocapkit.clean.knn import K_NEIGHBOURS, Context, GroupNeighbours, search_group, warp_word
from mocapkit.clean.texture import interpolate_track, make_texture, texture_from_rotations
from mocapkit.clean.words import ANALYSIS_FPS, JointGroup, source_word_starts, word_lengths
from mocapkit.core import rotations as rot
from mocapkit.core.motion import Motion
from mocapkit.core.skeleton import Skeleton


def _full_layout(
    sparse: Motion, full: Skeleton, known: Sequence[str] | None
) -> tuple[np.ndarray, list[int]]:
    """(F, J_full, 4) rotations of the sparse take on the full skeleton (identity where unknown)
    and the indices of the known joints."""
    names = list(full.names)
    F = sparse.num_frames
    out = rot.quat_identity((F, len(names)))
    if known is None:
        known = [n for n in sparse.skeleton.names if n in names]
    missing = [n for n in known if n not in names]
    if missing:
        raise ValueError(f"joints not in the database skeleton: {', '.join(missing)}")
    src_names = list(sparse.skeleton.names)
    idx = []
    for n in known:
        if n not in src_names:
            raise ValueError(f"joint {n!r} is not in the sparse take")
        j = names.index(n)
        out[:, j] = sparse.rotations[:, src_names.index(n)]
        idx.append(j)
    return out, sorted(set(idx))


def _database_skeleton(database: Sequence[Motion]) -> Skeleton:
    """The one skeleton of the database takes (checked by joint names)."""
    if not database:
        raise ValueError("the database needs at least one take")
    full = database[0].skeleton
    for m in database[1:]:
        if list(m.skeleton.names) != list(full.names):
            raise ValueError("database takes must share one skeleton")
    return full


def _analysis_texture(sparse: Motion, full: Skeleton, rots: np.ndarray, fps: float) -> np.ndarray:
    """(F_a, J_full, 4) analysis texture at ``fps`` of the sparse take laid out on the full
    skeleton (``rots``, from :func:`_full_layout`)."""
    if abs(sparse.fps - fps) > 1e-6 * fps:
        partial = Motion(full, rots, np.zeros((sparse.num_frames, 3)), sparse.frame_time)
        return texture_from_rotations(features.resample(partial, fps).rotations)
    return texture_from_rotations(rots)


def _word_candidates(
    ctx: Context,
    gn: GroupNeighbours,
    distances: np.ndarray,
    w: int,
    source_len: int,
    target_len: int,
    max_run: int,
) -> list[tuple[float, np.ndarray]]:
    """(word distance, full-body neighbour word (N, J, 4)) of each neighbour found for source
    word ``w``: its target word warped along the DTW path of the known joints."""
    N, M = source_len, target_len
    a = gn.starts[w]
    cands = []
    for r in range(gn.index.shape[1]):
        t0 = gn.index[w, r]
        if t0 < 0:
            continue
        block = distances[a : a + N, t0 : t0 + M]
        _, path = constrained_dtw(block, max_run)
        word = warp_word(ctx.rotations[t0 : t0 + M], path, N)
        cands.append((gn.distance[w, r], word))
    return cands


def _chain_words(
    ctx: Context,
    gn: GroupNeighbours,
    distances: np.ndarray,
    source_len: int,
    target_len: int,
    max_run: int,
    transition_weight: float,
) -> list[np.ndarray | None]:
    """One full-body word per source word (None where no neighbour was found): the first word
    takes its nearest neighbour, every later one the neighbour minimising its word distance plus
    ``transition_weight`` times the mean pose distance to the previous choice over the frames
    they share."""
    N = source_len
    chosen: list[np.ndarray | None] = []
    prev = None
    for w, a in enumerate(gn.starts):
        cands = _word_candidates(ctx, gn, distances, w, N, target_len, max_run)
        if not cands:
            chosen.append(None)
            continue
        if prev is None:
            best = min(cands, key=lambda c: c[0])[1]
        else:
            pa, pword = prev
            ov = pa + N - a  # overlapping frames with the previous word
            if ov > 0:
                costs = [
                    d + transition_weight * float(np.mean(pose_distance(wd[:ov], pword[a - pa :])))
                    for d, wd in cands
                ]
            else:
                costs = [d for d, _ in cands]
            best = cands[int(np.argmin(costs))][1]
        chosen.append(best)
        prev = (int(a), best)
    return chosen


def _blend_words(
    chosen: Sequence[np.ndarray | None],
    starts: np.ndarray,
    source_len: int,
    num_frames: int,
    num_joints: int,
) -> np.ndarray:
    """(num_frames, J, 4) texture of the chosen words (``source_len`` frames each, starting at
    ``starts``) blended with triangular weights, each word on the hemisphere of the one before
    (identity where no word covers a frame)."""
    N = source_len
    acc = np.zeros((num_frames, num_joints, 4))
    tri = 1.0 - np.abs(np.arange(N) - (N - 1) / 2) / ((N + 1) / 2)
    ref = None
    for a, word in zip(starts, chosen, strict=True):
        if word is None:
            continue
        if ref is None:
            ref = word[0]
        word = np.where(np.sum(word * ref, axis=-1, keepdims=True) < 0, -word, word)
        acc[a : a + N] += word * tri[:, None, None]
        ref = word[-1]
    n = np.linalg.norm(acc, axis=-1, keepdims=True)
    rec = np.where(n > 1e-12, acc / np.where(n > 0, n, 1.0), rot.quat_identity((1, 1)))
    return texture_from_rotations(rec)


def _to_take_frames(rec: np.ndarray, fps: float, sparse: Motion) -> np.ndarray:
    """The analysis texture ``rec`` (at ``fps``) slerped to the take's frames and smoothed with
    a quadratic Savitzky-Golay filter over about 0.2 s."""
    times = np.arange(sparse.num_frames) * sparse.frame_time
    rec_f = interpolate_track(rec, fps, times)
    win = max(5, round(0.2 * sparse.fps) | 1)
    if sparse.num_frames >= win:
        rec_f = rot.quat_normalize(savgol_filter(rec_f, win, 2, axis=0, mode="interp"))
    return rec_f


def reconstruct(
    sparse: Motion,
    database: Sequence[Motion],
    known: Sequence[str] | None = None,
    k: int = K_NEIGHBOURS,
    fps: float = ANALYSIS_FPS,
    max_run: int = MAX_RUN,
    transition_weight: float = 1.0,
) -> Motion:
    """Rebuild every joint of ``sparse`` from a database of complete takes.

    Args:
        sparse: the take; its skeleton is either the database's (then ``known`` names the joints
            to trust) or a subset of it by joint name.
        database: complete takes on one skeleton.
        known: joint names to keep; default: the sparse skeleton's joints found in the database
            skeleton. The pelvis, whose rotation carries the heading, does not take part in the
            search (it is still copied when known).
        k: candidates per word.
        transition_weight: weight of the overlap pose distance when chaining words.

    Returns:
        A Motion on the database skeleton at the input's frame rate: known joints and their
        translations (the root's, and those of joints that animate their position) copied from
        the input, the other joints reconstructed; a ground root on the body's ground path.
    """
    full = _database_skeleton(database)
    rots, kidx = _full_layout(sparse, full, known)
    pelvis = features.pelvis_index(full)
    search_joints = [j for j in kidx if j != pelvis]
    if len(search_joints) < 2:
        raise ValueError("at least two known joints (besides the pelvis) are needed")
    src = _analysis_texture(sparse, full, rots, fps)
    ctx = Context.build([make_texture(m, fps).rotations for m in database])
    N, step, M = word_lengths(fps)
    if src.shape[0] < N:
        raise ValueError(f"the take is too short: {src.shape[0]} analysis frames, a word needs {N}")
    starts = source_word_starts(src.shape[0], N, step)
    trim = 1 if len(search_joints) >= 4 else 0
    group = JointGroup("known", tuple(search_joints), trim)
    D = pose_distance_matrices(src, ctx.rotations, [group])[0]
    gn = search_group(src, ctx, group, starts, N, M, k, 0, max_run, distances=D)
    chosen = _chain_words(ctx, gn, D, N, M, max_run, transition_weight)
    rec = _blend_words(chosen, starts, N, src.shape[0], full.num_joints)
    out = _to_take_frames(rec, fps, sparse)
    out[:, kidx] = rots[:, kidx]
    root = np.asarray(sparse.root_positions, dtype=np.float64).copy()
    trans = None
    if sparse.translations is not None or full.has_position[1:].any():
        # joints that animate their position (a Bandai body under its ground root) keep the
        # take's translations where the take has the joint, their offsets elsewhere
        trans = np.broadcast_to(full.offsets, (sparse.num_frames, full.num_joints, 3)).copy()
        have = sparse.local_translations()
        src_names = list(sparse.skeleton.names)
        for j, name in enumerate(full.names):
            if name in src_names and full.has_position[j]:
                trans[:, j] = have[:, src_names.index(name)]
        trans[:, 0] = root
    # a ground root (Bandai's joint_Root) stands under the body, turned with it
    return features.ground_root_on_path(Motion(full, out, root, sparse.frame_time, trans))
