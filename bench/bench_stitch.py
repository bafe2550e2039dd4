"""Transition-search speed: every landing frame of a 100,000-frame library, k = 0..30, in one run.

Usage::

    python bench/bench_stitch.py [--frames N] [--data DIR] [--repeats N] [--pykalman-landings N]
                                 [--threads N] [--json]

Library: the shared bandai2 takes (``../shared/data/bandai2/data``, 30 fps, 22 joints), read with
mocapkit, turned into the stitching features (body-local positions of the 21 body joints, the
static ``joint_Root`` dropped: m = 63) and cut to ``--frames`` frames (default 100,000; bandai1
takes are added if bandai2 has fewer). The features are cached in ``$TMPDIR`` so that reruns skip
the parsing; reading and feature time are printed separately and not counted.

Query: a bandai1 walk take, take-off frame 60, window w = 5.

Timed (best and median of ``--repeats`` after one untimed warm-up that also compiles numba):
:func:`mocapkit.stitch.search_features` over all clips — every landing frame of every clip
(windows never straddle two clips), k = 0..30, L* and k_opt per landing, the best stitch re-scored
in float64. Frames searched per second = landing frames / seconds.

Reference: a straightforward per-window implementation with pykalman — for each landing frame,
each k and each of the 63 dimensions, build the elongated series (k masked observations), run
``KalmanFilter.smooth`` and sum |Δp̂ · â| — timed on ``--pykalman-landings`` landing frames and
extrapolated linearly to the whole library; its scores are checked against the fast path.
(The paper reports about 2.5 hours for its search.)
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

REPO_ROOT = Path(__file__).resolve().parent.parent
TARGET_S = 2.0


def shared_root() -> Path:
    env = os.environ.get("MOCAPKIT_SHARED")
    return Path(env).expanduser() if env else REPO_ROOT.parent / "shared"


def _mocapkit():
    try:
        import mocapkit  # noqa: F401
    except ImportError:
        sys.path.insert(0, str(REPO_ROOT / "src"))


def load_library(frames: int, data_dirs: list[Path]) -> tuple[list[np.ndarray], dict]:
    """Feature clips (F_i, 63) totalling ``frames`` frames, and timing/info."""
    from mocapkit.io import read_motion
    from mocapkit.stitch import motion_features

    files = [f for d in data_dirs for f in sorted(d.glob("*.bvh"))]
    if not files:
        raise SystemExit(f"no BVH files in {', '.join(map(str, data_dirs))}")
    key = f"mocapkit_bench_stitch_{len(files)}_{frames}.npz"
    cache = Path(os.environ.get("TMPDIR", "/tmp")) / key
    t0 = time.perf_counter()
    if cache.exists():
        z = np.load(cache)
        feats, lengths = z["feats"], z["lengths"]
        info = {"source": f"cache {cache}", "files": int(z["files"])}
    else:
        clips, total, used = [], 0, 0
        for f in files:
            m = read_motion(f)
            x = motion_features(m, up="Y").astype(np.float32)
            clips.append(x[: frames - total])
            total += clips[-1].shape[0]
            used += 1
            if total >= frames:
                break
        feats = np.concatenate(clips)
        lengths = np.array([c.shape[0] for c in clips])
        np.savez(cache, feats=feats, lengths=lengths, files=used)
        info = {"source": "BVH files", "files": used}
    info["load_s"] = time.perf_counter() - t0
    clips = np.split(feats, np.cumsum(lengths)[:-1])
    return clips, info


def pykalman_lk(window: np.ndarray, w: int, k_max: int, model) -> np.ndarray:
    """L_0..L_kmax of one (2w, m) window with pykalman, one series at a time."""
    from pykalman import KalmanFilter

    out = np.zeros(k_max + 1)
    for k in range(k_max + 1):
        mask = np.r_[np.ones(w, bool), np.zeros(k, bool), np.ones(w, bool)]
        for d in range(window.shape[1]):
            y = np.r_[window[:w, d], np.zeros(k), window[w:, d]]
            kf = KalmanFilter(
                transition_matrices=model.A,
                observation_matrices=model.C,
                transition_covariance=model.Q,
                observation_covariance=model.R,
                initial_state_mean=model.mu0_matrix @ y[:3],
                initial_state_covariance=model.P0,
            )
            z, _ = kf.smooth(np.ma.masked_array(y[:, None], mask=~mask[:, None]))
            p, a = z[:, 0], z[:, 2]
            out[k] += np.abs((p[1:] - p[:-1]) * a[:-1]).sum()
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--frames", type=int, default=100_000)
    ap.add_argument("--data", type=Path, default=None, help="folder of BVH takes (library)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--pykalman-landings", type=int, default=1)
    ap.add_argument("--k-max", type=int, default=30)
    ap.add_argument("--threads", type=int, default=None, help="numba threads (default: all)")
    ap.add_argument("--json", action="store_true", help="print the results as JSON")
    args = ap.parse_args(argv)
    _mocapkit()
    import numba

    from mocapkit.io import read_motion
    from mocapkit.stitch import DEFAULT_MODEL, motion_features, search_features, sliding_windows
    from mocapkit.stitch.lscore import search_landings

    if args.threads:
        numba.set_num_threads(args.threads)
    root = shared_root() / "data"
    dirs = [args.data] if args.data else [root / "bandai2" / "data", root / "bandai1" / "data"]
    clips, info = load_library(args.frames, dirs)
    n_frames = sum(c.shape[0] for c in clips)
    m = clips[0].shape[1]
    qfile = sorted((root / "bandai1" / "data").glob("*walk_normal*.bvh"))
    qm = read_motion(qfile[0]) if qfile else None
    Q = motion_features(qm, up="Y") if qm is not None else clips[0]
    a, w, k_max = min(60, Q.shape[0] - 1), 5, args.k_max

    t0 = time.perf_counter()
    search_landings(Q, a, clips[0][:200], w, k_max)  # compile / load the numba cache
    compile_s = time.perf_counter() - t0
    search_features(Q, a, clips, w=w, k_max=k_max)  # warm-up
    times = []
    for _ in range(args.repeats):
        t0 = time.perf_counter()
        best = search_features(Q, a, clips, w=w, k_max=k_max)
        times.append(time.perf_counter() - t0)
    t_best, t_med = min(times), float(np.median(times))
    n_land = best.candidates

    # pykalman reference on a few landing frames of the first clip (incl. the best one's clip)
    X = clips[best.clip]
    lands = [best.landing, *range(min(X.shape[0] - w + 1, args.pykalman_landings - 1))]
    lands = lands[: args.pykalman_landings]
    wins = sliding_windows(Q, a, X, w, landings=lands).astype(float)
    t0 = time.perf_counter()
    ref = np.stack([pykalman_lk(win, w, k_max, DEFAULT_MODEL) for win in wins])
    t_pyk = time.perf_counter() - t0
    fast = search_landings(Q, a, X, w, k_max, dtype=np.float64).lscore_by_k[lands]
    rel = float(np.max(np.abs(ref - fast) / np.maximum(np.abs(ref), 1e-12)))
    per_landing = t_pyk / len(lands)
    pyk_total = per_landing * n_land
    res = {
        "library_frames": n_frames,
        "clips": len(clips),
        "features": m,
        "landings": n_land,
        "k_max": k_max,
        "window": w,
        "threads": numba.get_num_threads(),
        "load_s": round(info["load_s"], 3),
        "load_source": info["source"],
        "compile_s": round(compile_s, 3),
        "search_best_s": round(t_best, 4),
        "search_median_s": round(t_med, 4),
        "frames_per_s": round(n_land / t_best),
        "library_frames_per_s": round(n_frames / t_best),
        "target_s": TARGET_S,
        "meets_target": bool(t_best <= TARGET_S),
        "best": {"clip": best.clip, "landing": best.landing, "k": best.k, "lscore": best.lscore},
        "pykalman_landings": len(lands),
        "pykalman_s": round(t_pyk, 3),
        "pykalman_s_per_landing": round(per_landing, 4),
        "pykalman_extrapolated_s": round(pyk_total, 1),
        "speedup_vs_pykalman": round(pyk_total / t_best),
        "pykalman_max_rel_diff": rel,
    }
    if args.json:
        print(json.dumps(res, indent=2))
        return 0
    print(
        f"library: {n_frames} frames x {m // 3} joints ({m} features) in {len(clips)} clips "
        f"[{info['source']}, loaded in {info['load_s']:.2f} s, not timed]"
    )
    print(
        f"query: {qfile[0].name if qfile else 'clip 0'}, take-off {a}, w = {w}, k = 0..{k_max}, "
        f"{res['threads']} numba threads (compile/cache load {compile_s:.2f} s, not timed)"
    )
    print(
        f"search: {n_land} landing frames in {t_best:.3f} s (median {t_med:.3f} s of "
        f"{args.repeats}) -> {n_land / t_best:,.0f} landing frames/s "
        f"({n_frames / t_best:,.0f} library frames/s); target <= {TARGET_S} s: "
        f"{'met' if res['meets_target'] else 'NOT met'}"
    )
    print(f"best: clip {best.clip}, landing {best.landing}, k = {best.k}, L* = {best.lscore:.6g}")
    print(
        f"pykalman per-window reference: {len(lands)} landings x {k_max + 1} k x {m} dims in "
        f"{t_pyk:.2f} s = {per_landing:.3f} s/landing -> {pyk_total / 3600:.1f} h for the "
        f"library (extrapolated); speed-up {pyk_total / t_best:,.0f}x; max rel. diff of L_k "
        f"{rel:.1e}"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
