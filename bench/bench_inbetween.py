"""In-betweening from a library (issue #18) on Bandai data, with the LaFAN1 benchmark protocol.

Usage::

    python bench/bench_inbetween.py [--shared DIR] [--tune] [--max-takes N per class] [--json]

Protocol (Harvey et al., "Robust Motion In-betweening", SIGGRAPH 2020, and its published
benchmark code for LaFAN1), on Bandai-Namco data (30 fps, cm, Y up):

* **Split.** Library: ``bandai2`` less a tenth of its takes (every tenth take in name order,
  kept out for tuning). Test windows: the walks (forward, back, left, right), runs and dashes of
  ``bandai1`` — no test take is in the library. ``--tune`` instead evaluates on the tuning
  tenth's walks and runs, which is what the defaults of
  :class:`mocapkit.stitch.inbetween.InbetweenConfig` are chosen on. With ``--tune`` the
  library leaves out every take of the tuning take's style (``--holdout style``, the default),
  or every take of its person (``--holdout person``: Bandai-2's three actors, told apart by
  their pelvis offsets), or nothing (``--holdout none``): the test takes' people and styles
  are not in the library either, and a rule chosen with the test's own style at hand does not
  carry over (session 7: 0.26 on the tuning tenth with its style in the library, 0.75 on the
  test split). Leaving the person out is the closer stand-in for the test split (its people
  are Bandai-1's): L2P over interpolation at 15 / 30 frames 0.47 / 0.53 with the person out,
  0.42 / 0.45 with the style out (session 25, in one run), against 0.56 / 0.61 on the test
  split's forward walks and 0.53 / 0.63 on its runs. ``--holdout gait`` also leaves out every
  take of the tuning take's gait (walks; turning walks, both ways; runs), as the test's
  backward and sideways walks are in no take of the library: 0.59 / 0.70 (session 26), near
  the test split's 0.68 / 0.73 overall, where 165 of 341 windows are such walks.
* **Windows** of 65 frames every 40 frames; context = the 10 past frames and the first future
  frame (frame 10 + n); transition lengths n = 5, 15, 30, 45 (frames 10 .. 10+n-1 replaced).
* **Metrics** on the n transition frames, over the 21 body joints (the static ``joint_Root``
  left out: it is not a body part):

  - **L2Q**: global quaternions (w >= 0 made continuous in time from the context frames, which
    prediction and truth share), ``mean over windows and frames of sqrt(sum over joints and
    the 4 components of (q_pred - q_true)^2)``;
  - **L2P**: global positions, the window centred on the pelvis' ground position at the last
    context frame and turned to face +X there (facing from the body model,
    :func:`mocapkit.features.heading_angles`), normalised per coordinate by the mean and
    standard deviation of the library's windows (50 frames every 20, as the LaFAN1 code takes
    its training statistics), ``mean of sqrt(sum over joints x 3 coordinates of the squared
    normalised difference)``;
  - **NPSS** (:func:`npss`): normalized power spectrum similarity of the global quaternions.

* **Baselines**, as the LaFAN1 benchmark code defines them: zero-velocity (the last context
  frame held) and interpolation (root position and animated translations lerped, local
  rotations slerped, between the last context frame and the target frame); plus today's Kalman
  transition (:func:`mocapkit.stitch.inbetween.kalman_fill`, 5 past frames, the 1 future
  frame), and the issue's "forty-line" nearest-segment search (:class:`NearestSegment`: half
  of the library's walks and runs, the last two context poses and the target pose matched in
  hips-relative positions, aligned on the ground, end offsets blended linearly). Every method
  sees the same context: 10 past frames and 1 future frame. ``library`` is the default
  (Kalman fallback on), ``library-nofb`` the same fill never falling back.
* **Foot skate** (cm/s): ankles and toes, horizontal speed weighted by ``clip(2 - 2^(h/H), 0,
  1)`` with h the joint's height above its ground (5th percentile over the take) and H = 5 cm
  (the weighting of Zhang et al. 2018), averaged over the transition frames; the test takes'
  own (the true frames) for reference.
* **Search time**: one gap against a 100,000-frame library (bandai2, then non-test bandai1
  takes to fill), against ``mocapkit.stitch.search_features`` (stitch's library search, one
  take-off, k = 0..30) on the same library, both warm, in the same run.
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
LENGTHS = (5, 15, 30, 45)
N_PAST = 10
WINDOW, OFFSET = 65, 40
STATS_WINDOW, STATS_OFFSET = 50, 20
TEST_CLASSES = ("walk", "walk-back", "walk-left", "walk-right", "run", "dash")
TUNE_CLASSES = ("walk", "walk-turn-left", "walk-turn-right", "run")
METHODS = ("zerov", "interp", "kalman", "nearest", "library", "library-nofb")
SKATE_H_CM = 5.0


def shared_root(arg: Path | None) -> Path:
    if arg is not None:
        return arg
    env = os.environ.get("MOCAPKIT_SHARED")
    return Path(env).expanduser() if env else REPO_ROOT.parent / "shared"


def _mocapkit():
    try:
        import mocapkit  # noqa: F401
    except ImportError:
        sys.path.insert(0, str(REPO_ROOT / "src"))


def take_class(path: Path) -> str:
    """``dataset-1_walk-back_active_001.bvh`` -> ``walk-back``."""
    return path.stem.split("_")[1]


# ------------------------------------------------------------------------------------ metrics


def npss(truth: np.ndarray, pred: np.ndarray) -> float:
    """Normalized Power Spectrum Similarity (Gopalakrishnan et al., CVPR 2019), as the LaFAN1
    benchmark code computes it (``fast_npss``): ``truth``, ``pred`` (batch, time, channels).

    Per sequence and channel: the power spectrum over time ``|Re FFT|^2``, normalised to sum 1,
    its cumulative sum (a distribution over frequencies), and the earth mover's distance between
    the two cumulative spectra (L1 norm of their difference); the result is the average of these
    distances weighted by the true channel's total power. 0 = identical spectra.
    """
    gt_power = np.square(np.real(np.fft.fft(truth, axis=1)))
    pred_power = np.square(np.real(np.fft.fft(pred, axis=1)))
    gt_total = gt_power.sum(axis=1)
    pred_total = pred_power.sum(axis=1)
    gt_norm = gt_power / np.maximum(gt_total[:, None, :], 1e-300)
    pred_norm = pred_power / np.maximum(pred_total[:, None, :], 1e-300)
    emd = np.abs(np.cumsum(pred_norm, axis=1) - np.cumsum(gt_norm, axis=1)).sum(axis=1)
    return float(np.average(emd, weights=gt_total))


def _continuous(q: np.ndarray) -> np.ndarray:
    """Quaternions (T, J, 4) with each frame in the hemisphere of the previous one."""
    q = q.copy()
    for t in range(1, q.shape[0]):
        flip = np.sum(q[t] * q[t - 1], axis=-1) < 0
        q[t, flip] *= -1
    return q


class Frames:
    """Global quaternions and canonical positions of a window (body joints)."""

    def __init__(self, motion, body_idx, ref_frame: int, frame_of_ref=None):
        from mocapkit.core import rotations as rot
        from mocapkit.core.kinematics import forward_kinematics
        from mocapkit.features import heading_angles, root_trajectory

        pos, grot = forward_kinematics(motion)
        ref = frame_of_ref if frame_of_ref is not None else motion
        centre = root_trajectory(ref[ref_frame : ref_frame + 1], "Y")[0]  # (x, z)
        h = heading_angles(ref[ref_frame : ref_frame + 1], "Y")[0]
        # turn about +Y by (pi/2 - h): the facing (sin h, cos h) in (x, z) goes to +X
        a = np.pi / 2 - h
        q = np.array([np.cos(a / 2), 0.0, np.sin(a / 2), 0.0])
        p = pos[:, body_idx] - np.array([centre[0], 0.0, centre[1]])
        self.pos = rot.quat_apply(q, p)
        self.quat = _continuous(np.where(grot[..., :1] < 0, -grot, grot))[:, body_idx]


def foot_skate(pos: np.ndarray, ground: np.ndarray, fps: float) -> float:
    """Mean weighted horizontal speed (cm/s) of the foot joints ``pos`` (T, n, 3); the first
    frame is the one before the measured frames."""
    v = np.linalg.norm(np.diff(pos[..., [0, 2]], axis=0), axis=-1) * fps
    h = pos[1:, :, 1] - ground[None]
    w = np.clip(2.0 - np.power(2.0, h / SKATE_H_CM), 0.0, 1.0)
    return float((v * w).mean())


# ------------------------------------------------------------------------------------ data


def split_bandai2(folder: Path) -> tuple[list[Path], list[Path]]:
    files = sorted(folder.glob("*.bvh"))
    tune = files[5::10]
    keep = set(tune)
    return [f for f in files if f not in keep], tune


def windows_of(n_frames: int) -> list[int]:
    return list(range(0, n_frames - WINDOW + 1, OFFSET))


def library_stats(lib_motions, body_idx) -> tuple[np.ndarray, np.ndarray]:
    """Per-coordinate mean and std (21 x 3) of the library's canonical window positions."""
    chunks = []
    for m in lib_motions:
        for s in range(0, m.num_frames - STATS_WINDOW + 1, STATS_OFFSET):
            w = m[s : s + STATS_WINDOW]
            chunks.append(Frames(w, body_idx, N_PAST - 1).pos)
    allp = np.concatenate(chunks)
    return allp.mean(axis=0), allp.std(axis=0)


def interpolation(win, n: int):
    """The LaFAN1 interpolation baseline on frames N_PAST..N_PAST+n-1 of ``win``."""
    from mocapkit.core import rotations as rot
    from mocapkit.core.motion import Motion

    a, b = N_PAST - 1, N_PAST + n
    u = np.linspace(0.0, 1.0, n + 2)[1:-1]
    q0 = win.rotations[a]
    q1 = rot.quat_fix_hemisphere(win.rotations[b], q0)
    J = win.num_joints
    rots = rot.quat_slerp(
        np.broadcast_to(q0, (n, J, 4)), np.broadcast_to(q1, (n, J, 4)), u[:, None]
    )
    tr = win.local_translations()
    t = tr[a][None] * (1 - u[:, None, None]) + tr[b][None] * u[:, None, None]
    return Motion(win.skeleton, rots, t[:, 0], win.frame_time, t)


def zero_velocity(win, n: int):
    from mocapkit.core.motion import Motion

    a = N_PAST - 1
    tr = np.repeat(win.local_translations()[a : a + 1], n, axis=0)
    rots = np.repeat(win.rotations[a : a + 1], n, axis=0)
    return Motion(win.skeleton, rots, tr[:, 0], win.frame_time, tr)


class NearestSegment:
    """The issue's "forty-line" baseline: over half of the library's walks and runs (every
    other take in name order, prepared as the library is: clip's bone lengths, ground root on
    the path), the segment whose frames s-1, s and s+g+1 best match the last two context poses
    and the target pose in hips-relative positions (body-local, pelvis subtracted; sum of
    squared distances), aligned on the ground at the last context frame, its end offsets (every
    joint's local rotation and translation, at A-1 and at B) blended in linearly over the gap."""

    def __init__(self, lib, body_idx, drop=frozenset()):
        from mocapkit.features import local_positions

        keep = [
            i for i, n in enumerate(lib.names)
            if take_class(Path(n)).startswith(("walk", "run")) and i not in drop
            and not (lib.backwards and lib.backwards[i])  # the files as recorded
        ]  # fmt: skip
        self.motions = [lib.motions[i] for i in keep[::2]]
        self.body_idx = body_idx
        feats = [self._feats(m, local_positions) for m in self.motions]
        self.F = np.concatenate(feats)
        self.clip = np.concatenate([np.full(len(f), i) for i, f in enumerate(feats)])
        self.time = np.concatenate([np.arange(len(f)) for f in feats])

    def _feats(self, m, local_positions):
        from mocapkit.features import pelvis_index

        lp = local_positions(m, "Y")
        return (lp[:, self.body_idx] - lp[:, pelvis_index(m.skeleton)][:, None]).reshape(
            len(lp), -1
        )

    def fill(self, win, a, b):
        from mocapkit import features
        from mocapkit.core import rotations as rot
        from mocapkit.core.motion import Motion
        from mocapkit.stitch.inbetween import _back_to_clip

        g = b - a
        on = features.ground_root_on_path(win, "Y")
        c = self._feats(on, features.local_positions)
        F, N = self.F, len(self.F)
        s = np.arange(1, N - g - 1)
        cost = (((F[s - 1] - c[a - 2]) ** 2).sum(1) + ((F[s] - c[a - 1]) ** 2).sum(1)
                + ((F[s + g + 1] - c[b]) ** 2).sum(1))  # fmt: skip
        cost[self.clip[s - 1] != self.clip[s + g + 1]] = np.inf
        i = int(s[np.argmin(cost)])
        src = self.motions[self.clip[i]]
        t0 = int(self.time[i])
        seg = src[t0 : t0 + g + 2]
        seg = features.apply_ground_transform(
            seg, features.ground_alignment(on, a - 1, seg, 0, "Y")
        )
        u = (np.arange(g + 2) / (g + 1))[:, None, None]
        r, tr, ct = seg.rotations, seg.local_translations(), on.local_translations()
        d0 = rot.quat_mul(on.rotations[a - 1], rot.quat_inv(r[0]))
        d1 = rot.quat_mul(on.rotations[b], rot.quat_inv(r[-1]))
        d0, d1 = (np.where(d[..., :1] < 0, -d, d) for d in (d0, d1))
        off = rot.quat_exp(rot.quat_log(d0)[None] * (1 - u) + rot.quat_log(d1)[None] * u)
        r = rot.quat_normalize(rot.quat_mul(off, r))[1:-1]
        tr = (tr + (ct[a - 1] - tr[0])[None] * (1 - u) + (ct[b] - tr[-1])[None] * u)[1:-1]
        fill = Motion(win.skeleton, r, tr[:, 0], win.frame_time, tr)
        return _back_to_clip(fill, win, a, b, on is not win)


# ------------------------------------------------------------------------------------ run


def take_style(path: Path) -> str:
    """``dataset-2_walk_active_001.bvh`` -> ``active``."""
    return path.stem.split("_")[2]


def person_of(files: list[Path], motions=None):
    """A function naming the person of a take in ``files`` (``Path`` or its name as a string):
    its pelvis' offset in the file (``motions``: the files read, where at hand). Bandai's takes
    share one skeleton but each actor's hips sit at their own offset from the root, so takes
    with the same offset are one person's."""
    from mocapkit.body import body_of
    from mocapkit.io import read_motion

    motions = motions or [None] * len(files)
    key = {}
    for f, m in zip(files, motions, strict=True):
        sk = (m if m is not None else read_motion(f)).skeleton
        key[str(f)] = tuple(np.round(sk.offsets[body_of(sk).pelvis], 1))
    return lambda f: key[str(f)]


def gait_of(path: Path) -> str:
    """The gait of a take: its class, the two turning walks taken as one (a library that
    holds one holds the other's mirror image)."""
    c = take_class(Path(path))
    return "walk-turn" if c.startswith("walk-turn") else c


def holdout_groups(holdout: str, person_of):
    """A function giving a take's groups for ``--holdout``: its style, its person, or its person
    and its gait. A library take sharing any group with the tuning take is left out."""
    return {
        "style": lambda f: frozenset({("style", take_style(Path(f)))}),
        "person": lambda f: frozenset({("person", person_of(f))}),
        "gait": lambda f: frozenset({("person", person_of(f)), ("gait", gait_of(f))}),
    }[holdout]


def library_without(lib, drop: set[int]):
    """``lib`` (an InbetweenLibrary) searching only the clips not in ``drop`` (indices into
    its motions, which stay as they are, so candidates keep their clip numbers)."""
    from dataclasses import replace

    warped = []
    for W in lib.warped:
        keep = ~np.isin(W.clip, sorted(drop))
        warped.append(type(W)(W.rate, np.ascontiguousarray(W.feats[keep]), W.ground[keep],
                              W.heading[keep], W.clip[keep], W.time[keep],
                              None if W.pelvis is None else W.pelvis[keep]))  # fmt: skip
    return replace(
        lib,
        warped=tuple(warped),
        frames=sum(  # the files as recorded, not their reversed copies
            m.num_frames
            for i, m in enumerate(lib.motions)
            if i not in drop and not (lib.backwards and lib.backwards[i])
        ),
    )


def evaluate(
    test_files,
    lib,
    stats,
    body_idx,
    feet_idx,
    config,
    max_takes=None,
    log=print,
    nearest=None,
    holdout=None,
    person_of=None,
):
    """Per (class, method, n): lists of per-window L2Q, L2P and the quaternion sequences."""
    from mocapkit.core.kinematics import forward_kinematics
    from mocapkit.core.motion import concatenate
    from mocapkit.features import ground_root_on_path
    from mocapkit.io import read_motion
    from mocapkit.stitch.inbetween import (
        _back_to_clip,
        inbetween,
        kalman_fill,
        kalman_max_frames,
    )

    mean, std = stats
    rec: dict = {}
    fallbacks: dict = {}
    times = []
    files = test_files
    if max_takes:  # the first max_takes takes of each class, in name order
        same = {f: [g for g in test_files if take_class(g) == take_class(f)] for f in files}
        rank = {f: same[f].index(f) for f in files}
        files = [f for f in test_files if rank[f] < max_takes]
    full_lib, by_style = lib, {}
    for ti, f in enumerate(files):
        take = read_motion(f)
        cls = take_class(f)
        if holdout:  # the library (and the baseline's) without the take's style, person, gait
            group = holdout_groups(holdout, person_of)
            st = group(f)
            if st not in by_style:
                drop = {i for i, n in enumerate(full_lib.names) if group(Path(n)) & st}
                sub = library_without(full_lib, drop)
                by_style[st] = (sub, NearestSegment(full_lib, body_idx, drop))
            lib, nearest = by_style[st]
        Pt, _ = forward_kinematics(take)
        ground = np.percentile(Pt[:, feet_idx, 1], 5, axis=0)
        for s in windows_of(take.num_frames):
            for n in LENGTHS:
                win = take[s : s + N_PAST + n + 1]
                truth = Frames(win, body_idx, N_PAST - 1)
                sl = slice(N_PAST, N_PAST + n)
                t0 = time.perf_counter()
                # the library fill and, only where "auto" falls back, the Kalman fill (one search
                # each): "library" never falls back, "auto" is the default
                res_lib = inbetween(win, (N_PAST, N_PAST + n), lib, config=config, up="Y",
                                    future_frames=1, method="library")  # fmt: skip
                res = res_lib
                if (
                    config.fallback
                    and n <= kalman_max_frames(win, config)
                    and res_lib.library_lscore > config.fallback_margin * res_lib.kalman_lscore
                ):
                    res = inbetween(win, (N_PAST, N_PAST + n), lib, config=config, up="Y",
                                    future_frames=1, method="kalman")  # fmt: skip
                times.append(time.perf_counter() - t0)
                kal = _back_to_clip(
                    kalman_fill(ground_root_on_path(win, "Y"), N_PAST, N_PAST + n, future_frames=1),
                    win, N_PAST, N_PAST + n, True,
                )  # fmt: skip
                fallbacks.setdefault((cls, n), []).append(res is not res_lib)
                outs = {
                    "zerov": concatenate([win[:N_PAST], zero_velocity(win, n), win[N_PAST + n :]]),
                    "interp": concatenate([win[:N_PAST], interpolation(win, n), win[N_PAST + n :]]),
                    "kalman": concatenate([win[:N_PAST], kal, win[N_PAST + n :]]),
                    "nearest": concatenate(
                        [win[:N_PAST], nearest.fill(win, N_PAST, N_PAST + n), win[N_PAST + n :]]
                    ),
                    "library": res.motion,
                    "library-nofb": res_lib.motion,
                }
                for meth, out in outs.items():
                    fr = Frames(out, body_idx, N_PAST - 1, frame_of_ref=win)
                    dp = ((fr.pos[sl] - truth.pos[sl]) / std).reshape(n, -1)
                    dq = (fr.quat[sl] - truth.quat[sl]).reshape(n, -1)
                    Po, _ = forward_kinematics(out[N_PAST - 1 : N_PAST + n])
                    keys = ("l2p", "l2q", "qp", "qt", "skate", "skate_true")
                    r = rec.setdefault((cls, meth, n), {k: [] for k in keys})
                    r["l2p"].append(float(np.sqrt((dp**2).sum(-1)).mean()))
                    r["l2q"].append(float(np.sqrt((dq**2).sum(-1)).mean()))
                    r["qp"].append(fr.quat[sl].reshape(n, -1))
                    r["qt"].append(truth.quat[sl].reshape(n, -1))
                    r["skate"].append(foot_skate(Po[:, feet_idx], ground, take.fps))
                    r["skate_true"].append(
                        foot_skate(
                            Pt[s + N_PAST - 1 : s + N_PAST + n][:, feet_idx], ground, take.fps
                        )
                    )
        log(f"  [{ti + 1}/{len(files)}] {f.name}")
    del mean
    return rec, fallbacks, times


def summarise(rec, fallbacks, classes):
    rows = []
    for cls in [*classes, "all"]:
        for n in LENGTHS:
            for meth in METHODS:
                keys = [(c, meth, n) for c in classes] if cls == "all" else [(cls, meth, n)]
                parts = [rec[k] for k in keys if k in rec]
                if not parts:
                    continue
                l2p = np.concatenate([p["l2p"] for p in parts])
                l2q = np.concatenate([p["l2q"] for p in parts])
                qp = np.stack([x for p in parts for x in p["qp"]])
                qt = np.stack([x for p in parts for x in p["qt"]])
                sk = np.concatenate([p["skate"] for p in parts])
                skt = np.concatenate([p["skate_true"] for p in parts])
                fb = [
                    x
                    for c in (classes if cls == "all" else [cls])
                    for x in fallbacks.get((c, n), [])
                ]
                rows.append({
                    "class": cls, "n": n, "method": meth, "windows": len(l2p),
                    "l2q": float(l2q.mean()), "l2p": float(l2p.mean()), "npss": npss(qt, qp),
                    "skate": float(sk.mean()), "skate_true": float(skt.mean()),
                    "fallbacks": int(sum(fb)) if meth == "library" else None,
                })  # fmt: skip
    for r in rows:
        ref = next(x for x in rows if x["class"] == r["class"] and x["n"] == r["n"]
                   and x["method"] == "interp")  # fmt: skip
        for k in ("l2q", "l2p", "npss"):
            r[f"{k}_ratio"] = r[k] / ref[k] if ref[k] > 0 else float("nan")
    return rows


def print_table(rows, title):
    print(f"\n{title}")
    print("| class | windows | n | method | L2Q | L2P | NPSS | L2Q/interp | L2P/interp | "
          "NPSS/interp | skate cm/s (true) | fallbacks |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        fb = "" if r["fallbacks"] is None else str(r["fallbacks"])
        print(
            f"| {r['class']} | {r['windows']} | {r['n']} | {r['method']} | {r['l2q']:.3f} | "
            f"{r['l2p']:.3f} | {r['npss']:.4f} | {r['l2q_ratio']:.2f} | {r['l2p_ratio']:.2f} | "
            f"{r['npss_ratio']:.2f} | {r['skate']:.2f} ({r['skate_true']:.2f}) | {fb} |"
        )


def search_timing(lib_files, extra_files, reference, config):
    """(inbetween search s, stitch search s, frames, inbetween search s with cold caches) on a
    100,000-frame library; the in-betweening's search is for a fill's ``neighbours`` segments,
    as :func:`inbetween` runs it. Warm: the library's squared feature norms cached, as when one
    prepared library fills many gaps; cold: the first search, which computes them (a library
    with the clip's own frames added is new for each gap)."""
    from mocapkit.features import ground_root_on_path
    from mocapkit.io import read_motion
    from mocapkit.stitch import search_features
    from mocapkit.stitch.inbetween import gap_context, prepare_library, search_inbetween_top

    motions, total = [], 0
    for f in [*lib_files, *extra_files]:
        m = read_motion(f)
        m = m[: 100_000 - total]
        motions.append(m)
        total += m.num_frames
        if total >= 100_000:
            break
    lib = prepare_library(motions, reference, up="Y", config=config)
    feats = [w for w in lib.warped if w.rate == 1.0]
    if not feats:
        raise SystemExit("the timing needs the warp 1.0 in the config")
    W = feats[0]
    clips = [W.feats[W.clip == i] for i in range(len(motions))]
    from mocapkit.stitch import motion_features

    qf = motion_features(reference, "Y")
    a = min(60, reference.num_frames // 3)
    b = min(a + 30, reference.num_frames - 5)
    ctx = gap_context(ground_root_on_path(reference, "Y"), a, b, 5, "Y", None)
    cold = None
    for _ in range(2):  # warm-up (numba compile; the norms' cache), then timed
        t0 = time.perf_counter()
        search_features(qf, a - 1, clips, k_max=30)
        t_stitch = time.perf_counter() - t0
        t0 = time.perf_counter()
        k = config.neighbours
        search_inbetween_top(ctx, b - a, lib, k, w=5, config=config)
        t_inb = time.perf_counter() - t0
        cold = t_inb if cold is None else cold
    return t_inb, t_stitch, total, cold


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--shared", type=Path, default=None)
    ap.add_argument("--tune", action="store_true", help="evaluate on the tuning takes")
    ap.add_argument(
        "--holdout",
        choices=("style", "person", "gait", "none"),
        default="style",
        help="with --tune: leave out of the library every take of the tuning take's style "
        "(default), of its person, of its person or its gait, or none",
    )
    ap.add_argument("--max-takes", type=int, default=None, help="per class")
    ap.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE",
                    help="override an InbetweenConfig field (tuning)")  # fmt: skip
    ap.add_argument("--no-timing", action="store_true")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    _mocapkit()
    from dataclasses import replace

    from mocapkit.io import read_motion
    from mocapkit.stitch import body_joints
    from mocapkit.stitch.inbetween import DEFAULT_CONFIG, prepare_library

    config = DEFAULT_CONFIG
    for s in args.set:
        k, v = s.split("=", 1)
        cur = getattr(config, k)
        if isinstance(cur, tuple):
            val = tuple(float(x) for x in v.split(","))
        elif isinstance(cur, bool):  # bool("False") is True
            val = v.strip().lower() in ("1", "true", "yes", "on")
        else:
            val = type(cur)(v)
        config = replace(config, **{k: val})
    root = shared_root(args.shared) / "data"
    lib_files, tune_files = split_bandai2(root / "bandai2" / "data")
    b1 = sorted((root / "bandai1" / "data").glob("*.bvh"))
    if args.tune:
        classes = TUNE_CLASSES
        test_files = [f for f in tune_files if take_class(f) in classes]
    else:
        classes = TEST_CLASSES
        test_files = [f for f in b1 if take_class(f) in classes]
    t0 = time.perf_counter()
    lib_motions = [read_motion(f) for f in lib_files]
    reference = read_motion(test_files[0])
    lib = prepare_library(lib_motions, reference, [str(f) for f in lib_files], up="Y",
                          config=config)  # fmt: skip
    body_idx = body_joints(reference.skeleton)
    feet_idx = _feet(reference)
    stats = library_stats(lib.motions[: len(lib_files)], body_idx)  # not the reversed copies
    print(f"library: {len(lib_files)} bandai2 takes, {lib.frames} frames "
          f"(tuning takes kept out: {len(tune_files)}); prepared in "
          f"{time.perf_counter() - t0:.1f} s; test: {len(test_files)} takes "
          f"({'tuning' if args.tune else 'bandai1'}); config {config}")  # fmt: skip
    rec, fallbacks, times = evaluate(
        test_files, lib, stats, body_idx, feet_idx, config, args.max_takes,
        log=lambda s: print(s, file=sys.stderr), nearest=NearestSegment(lib, body_idx),
        holdout=args.holdout if args.tune and args.holdout != "none" else None,
        person_of=person_of(lib_files + tune_files, lib_motions + [None] * len(tune_files)),
    )  # fmt: skip
    rows = summarise(rec, fallbacks, classes)
    print_table([r for r in rows if r["class"] == "all"], "All classes")
    print_table([r for r in rows if r["class"] != "all"], "Per class")
    print(f"\nin-betweening per gap (search + fill): median {np.median(times):.3f} s")
    timing = None
    if not args.no_timing:
        extra = [f for f in b1 if take_class(f) not in TEST_CLASSES]
        t_inb, t_st, frames, cold = search_timing(lib_files, extra, reference, config)
        timing = {"inbetween_s": t_inb, "stitch_s": t_st, "ratio": t_inb / t_st, "frames": frames,
                  "inbetween_cold_s": cold, "ratio_cold": cold / t_st}  # fmt: skip
        print(f"search over {frames} frames: inbetween {t_inb:.3f} s, stitch {t_st:.3f} s, "
              f"ratio {t_inb / t_st:.2f} (target <= 2); the first search, its caches cold, "
              f"{cold:.3f} s (ratio {cold / t_st:.2f})")  # fmt: skip
    if args.json:
        print(json.dumps({"rows": rows, "timing": timing}, indent=1))
    return 0


def _feet(motion) -> list[int]:
    from mocapkit.body import body_of

    return [j for _, j in body_of(motion).feet]


if __name__ == "__main__":
    raise SystemExit(main())
