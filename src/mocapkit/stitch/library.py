"""Stitching onto a library of files, in shards: each shard (a fixed run of files) is read and
searched by one task, which returns only its best candidate per take-off; the shards' bests are
merged in shard order. The tasks run wherever ``runner`` runs them (in this process, or on a
Dask cluster through :class:`mocapkit.batch.Runner`): no process but the workers reads the
library, none holds more than one shard's features, and the result is the same however many
workers there are, since the shards and the merge order depend on the file list only.

    from mocapkit.stitch.library import stitch_library
    res = stitch_library(query, "40:80", paths, runner=runner)   # a Stitched
    res.transition.clip          # index into paths; res.skipped: unreadable files
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from mocapkit.core.motion import Motion
from mocapkit.core.ranges import RangeSpec
from mocapkit.stitch.kalman import DEFAULT_MODEL, ConstantAccelerationModel
from mocapkit.stitch.lscore import DEFAULT_W
from mocapkit.stitch.search import (
    best_per_takeoff,
    check_search,
    check_takeoffs,
    conform,
    feature_joint_indices,
    merge_per_takeoff,
    motion_features,
    no_candidate,
    transition_at,
)
from mocapkit.stitch.transition import DEFAULT_BLEND_SECONDS, build_stitch

__all__ = ["SHARD_FILES", "LibraryShard", "ShardBest", "search_shard", "stitch_library"]

#: Files per shard: a fixed number (not a function of the number of workers), so the shards and
#: the merge are the same wherever the search runs; 32 Bandai takes are about 4,000 frames.
SHARD_FILES = 32


@dataclass(frozen=True)
class LibraryShard:
    """One task: ``paths[first:first + len(paths)]`` of the library."""

    index: int
    first: int
    paths: tuple[str, ...]


@dataclass(frozen=True)
class ShardBest:
    """What a shard's task returns: per take-off its best ``(value, clip, landing)`` (clip: the
    index in the whole library) or None, the candidates it scored, and the files it could not
    read or use (``(index, one-line reason)``)."""

    index: int
    per_takeoff: tuple[tuple[float, int, int] | None, ...]
    candidates: int
    skipped: tuple[tuple[int, str], ...]


@dataclass(frozen=True)
class _Search:
    """What every shard task needs (sent once to each worker)."""

    query: Motion
    features: np.ndarray
    takeoffs: tuple[int, ...]
    landing: RangeSpec | None  # a frame of each data file, or a time
    window: int
    k_max: int
    inject: int | None
    score: str
    model: ConstantAccelerationModel
    up: str
    joints: tuple[str, ...]
    lenient: bool


def file_to_query_frame(frame: int, file_fps: float, query_fps: float) -> int:
    """A data file's frame as a frame of the file resampled to the query's rate (the frames
    the search works on)."""
    if math.isclose(file_fps, query_fps, rel_tol=1e-6):
        return int(frame)
    return math.floor(frame * query_fps / file_fps + 0.5)


def _clip_features(path: str, s: _Search) -> tuple[np.ndarray, int | None]:
    """The clip's features at the query's rate, and the landing frame asked for (a frame of
    the file, or a time) as a frame of them."""
    from mocapkit.io import read_motion

    motion = read_motion(path, lenient=s.lenient)
    landing = None
    if s.landing is not None:
        landing = file_to_query_frame(s.landing.frames(motion.fps)[0], motion.fps, s.query.fps)
    return motion_features(conform(motion, s.query, path), s.up, list(s.joints)), landing


def search_shard(search: _Search, shard: LibraryShard) -> ShardBest:
    """Read one shard's files and search them (on whichever process runs the task)."""
    from mocapkit.io import MocapFileError

    clips: list[np.ndarray] = []
    where: list[int] = []
    lands: list[int | None] = []
    skipped: list[tuple[int, str]] = []
    for k, path in enumerate(shard.paths):
        try:
            feats, landing = _clip_features(path, search)
            clips.append(feats)
            lands.append(landing)
            where.append(shard.first + k)
        except (MocapFileError, ValueError, KeyError, OSError, IndexError) as e:
            msg = " ".join(str(e).split()) or type(e).__name__
            skipped.append((shard.first + k, msg if path in msg else f"{path}: {msg}"))
    per: list[tuple[float, int, int] | None] = [None] * len(search.takeoffs)
    candidates = 0
    # one search per landing frame: a frame of files at other rates is another frame here
    groups: dict[int | None, list[int]] = {}
    for i, landing in enumerate(lands):
        groups.setdefault(landing, []).append(i)
    for landing, idx in groups.items():
        best, n = best_per_takeoff(
            search.features, list(search.takeoffs), [clips[i] for i in idx], landing,
            search.window, search.k_max, search.model, search.score, np.float32, search.inject,
        )  # fmt: skip
        candidates += n
        for t, b in enumerate(best):
            if b is None or not np.isfinite(b[0]):
                continue
            cand = (b[0], where[idx[b[1]]], b[2])
            if per[t] is None or cand[:2] < per[t][:2]:  # ties: the first clip
                per[t] = cand
    return ShardBest(shard.index, tuple(per), candidates, tuple(skipped))


def plan_shards(paths: Sequence[str | Path], shard_files: int = SHARD_FILES) -> list[LibraryShard]:
    """The library cut into runs of ``shard_files`` files, in the given order."""
    if shard_files < 1:
        raise ValueError(f"shard_files must be >= 1, got {shard_files}")
    ps = [str(p) for p in paths]
    return [
        LibraryShard(n, a, tuple(ps[a : a + shard_files]))
        for n, a in enumerate(range(0, len(ps), shard_files))
    ]


def stitch_library(
    query: Motion,
    takeoff,
    paths: Sequence[str | Path],
    landing: int | str | RangeSpec | None = None,
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
    lenient: bool = False,
    query_name: str = "query",
    output: str | None = None,
    runner: Any = None,
    progress: Callable[[int, int], None] | None = None,
    shard_files: int = SHARD_FILES,
) -> Any:
    """:func:`mocapkit.stitch.stitch` of ``query`` onto the best of the library files ``paths``,
    searched shard by shard (see the module docstring) on ``runner`` (anything with
    ``imap(fn, items, *, shared, progress, name)``, e.g. :class:`mocapkit.batch.Runner`;
    default: one after the other in this process). Only the chosen file is read here. A file
    that cannot be read or does not fit the query's skeleton is left out and listed in the
    result's ``skipped`` (``(path, reason)``); no usable file at all is a ValueError.

    ``landing``: a frame of each data file (an int, or ``"12"``) or a time (``"0.4s"``); None
    searches every landing frame. Frame numbers in the result (landing, the provenance's source
    frames) are the data file's own, also where it is at another rate than the query and was
    resampled to it for the search (``data_fps`` says so).
    Returns the :class:`~mocapkit.stitch.Stitched` with ``data_names`` = ``paths``."""
    from mocapkit.features import detect_up_axis
    from mocapkit.io import read_motion

    paths = [str(p) for p in paths]
    if not paths:
        raise ValueError("no data clip given")
    if landing is not None and not isinstance(landing, RangeSpec):
        if isinstance(landing, bool) or not isinstance(landing, int | np.integer | str):
            raise ValueError(f"landing: a frame (12) or a time ('0.4s'), got {landing!r}")
        landing = RangeSpec.parse(str(landing), "landing", single=True)
    if k_max is not None:
        if int(k_max) != k_max or k_max < 0:
            raise ValueError(f"k_max (--max-inject) must be an integer >= 0, got {k_max}")
        max_inject_seconds = int(k_max) * query.frame_time
    if not max_inject_seconds >= 0:
        raise ValueError(f"max_inject_seconds must be >= 0, got {max_inject_seconds}")
    kmax, k_show, inject, w, score = check_search(
        query.seconds_to_frames(max_inject_seconds), inject, window, score, method
    )
    up = up or detect_up_axis(query)
    names = tuple(query.skeleton.names[j] for j in feature_joint_indices(query.skeleton, joints))
    qf = np.asarray(motion_features(query, up, list(names)), dtype=float)
    takeoffs = check_takeoffs(takeoff, qf.shape[0], w)
    search = _Search(query, qf, tuple(takeoffs), landing, w, kmax, inject, score, model, up,
                     names, lenient)  # fmt: skip
    shards = plan_shards(paths, shard_files)
    t0 = time.perf_counter()
    if runner is None:
        parts: list[ShardBest] = []
        for n, sh in enumerate(shards, 1):
            parts.append(search_shard(search, sh))
            if progress is not None:
                progress(n, len(shards))
    else:
        parts = list(runner.imap(search_shard, shards, shared=search, progress=progress,
                                 name="stitch-shard"))  # fmt: skip
    skipped = [(paths[i], why) for p in parts for i, why in p.skipped]
    best = merge_per_takeoff([p.per_takeoff for p in parts])
    if best is None:
        if len(skipped) == len(paths):
            raise ValueError(f"no data clip could be used: {skipped[0][1]}")
        if landing is not None and not landing.text.strip().lstrip("-").isdigit():
            raise ValueError(
                f"landing {landing.text.strip()!r} has no full landing window ({w} frames from "
                "it) in any data clip"
            )
        raise no_candidate(None if landing is None else landing.frames(query.fps)[0], w)
    (_, ci, b), t = best
    data = read_motion(paths[ci], lenient=lenient)
    chosen = conform(data, query, paths[ci])
    clip = motion_features(chosen, up, list(names))
    tr = transition_at(qf, takeoffs[t], clip, ci, b, w, model, k_show, inject, score,
                       sum(p.candidates for p in parts))  # fmt: skip
    search_seconds = time.perf_counter() - t0
    res = build_stitch(
        query, tr, chosen, method=method, window=window, model=model, align=align, up=up,
        joints=joints, blend_seconds=blend_seconds,
    )  # fmt: skip
    out = replace(
        res,
        transition=tr,
        up=up,
        query_name=str(query_name),
        data_names=tuple(paths),
        takeoff_spec=takeoff if isinstance(takeoff, (str, int)) else list(takeoffs),
        search_seconds=search_seconds,
        output=None if output is None else str(output),
        skipped=tuple(skipped),
        data_fps=None if math.isclose(data.fps, query.fps, rel_tol=1e-6) else float(data.fps),
        data_frames=data.num_frames,
    )
    asked = None if landing is None or not landing.text.strip().isdigit() else int(landing.text)
    out.warn_if_landing_moved(asked)
    return out
