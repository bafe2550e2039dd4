"""Detection evaluation of mocapkit.clean on injected errors, with an honest split.

Rules and thresholds are chosen on the *tuning half* of Bandai-1 only; its *validation half*
decides whether a rule earns its place (``--ablate``: the pipeline without each rule, from the
same fits); Bandai-2 and the raw CMU ASF/AMC takes (another skeleton, 120 fps) are reported
without retuning. For every take and error kind, errors of that kind (one joint at a time, one
per ~2 s, seeded) are injected into the clean take (for CMU: the raw take, whose own glitches
are listed blind in tests/clean/fixtures/cmu_glitches.json from four signals independent of
the cleaner, :func:`find_glitches`, :func:`find_excursions`, :func:`find_holds` and
:func:`find_jitter`, their events judged by eye; a flag on one of them is neither a hit nor a
false alarm, nor is one on a frame an error rewrote by under a degree, ``Corrupted.rewritten``),
and the take is analysed with a local context (the take alone) and a small-scale
context (other takes of the same class and split). Units: (joint, source word)
(mocapkit.clean.evaluate), on the joints that rotate. With ``--raw`` the
uninjected CMU takes are analysed too: flagged segments off the glitch list per minute, and the
listed glitches hit.

    PYTHONPATH=src .venv/bin/python bench/eval_clean.py --set bandai1-tune [--ablate]
    PYTHONPATH=src .venv/bin/python bench/eval_clean.py --set bandai2 --set cmu --raw
    PYTHONPATH=src .venv/bin/python bench/eval_clean.py --set bandai1-tune --fps 120 \
        --class gestures

``--fps 120`` resamples the takes (slerp) before injecting: the tuning stand-in for CMU's rate.
``--class`` keeps one motion class. ``--min-seconds 2.5`` keeps the short takes too (half of
Bandai-1's gestures are under 5 s); ``--config hinge_bend_deg=0`` scores a changed
``DetectConfig``. The false alarms are also counted per rule that flagged them (reasons).

Sets: bandai1-tune, bandai1-val, bandai2, cmu. Classes: Bandai-1 locomotion (walk, walk-back,
-left, -right, run, dash), dance/fight (dance, kick, punch, slash) and gestures (bow, bye,
byebye, call, guide, respond); Bandai-2 locomotion
(walk, walk-turn-left/right, run) and gestures (raise-up-*, wave-*); CMU 01 playground and
03 walking.
"""

from __future__ import annotations

import argparse
import glob
import json
import os
import sys
import time
from pathlib import Path

import numpy as np
from scipy import ndimage

from mocapkit.body import body_of
from mocapkit.clean.cleaner import SelfSimilarityCleaner
from mocapkit.clean.detect import ORIGINAL_ORDER, PIPELINE, RETIRED, DetectConfig, run_pipeline
from mocapkit.clean.evaluate import Counts, corrupt, unit_matrix, unit_words
from mocapkit.clean.inject import ERROR_KINDS
from mocapkit.clean.repair import foot_slide
from mocapkit.clean.texture import rotating_joints
from mocapkit.core import rotations as rot
from mocapkit.core.kinematics import forward_kinematics
from mocapkit.features import foot_contacts, metres_per_unit, resample
from mocapkit.ik import leg_chains
from mocapkit.io import read_motion

ROOT = Path(__file__).resolve().parent.parent
SHARED = Path(os.environ.get("MOCAPKIT_SHARED", ROOT.parent / "shared")) / "data"
GLITCHES = ROOT / "tests" / "clean" / "fixtures" / "cmu_glitches.json"
MIN_SECONDS = 5.0  # a local context needs a few seconds of the take to find neighbours in


def _bvh(folder: str, prefixes: tuple[str, ...]) -> list[str]:
    d = SHARED / folder / "data"
    return sorted(f for f in glob.glob(str(d / "*.bvh")) if Path(f).name.split("_")[1] in prefixes)


def _spread(files: list[str], n: int) -> list[str]:
    """``n`` files spread evenly over a sorted list (deterministic)."""
    if len(files) <= n:
        return files
    idx = np.unique(np.linspace(0, len(files) - 1, n).round().astype(int))
    return [files[i] for i in idx]


def classes(set_name: str) -> dict[str, list[str]]:
    """The takes of a set per motion class (before ``--takes`` and the duration filter)."""
    if set_name.startswith("bandai1"):
        loco = _bvh("bandai1", ("walk", "walk-back", "walk-left", "walk-right", "run", "dash"))
        dance = _bvh("bandai1", ("dance-short", "dance-long", "kick", "punch", "slash"))
        gest = _bvh("bandai1", ("bow", "bye", "byebye", "call", "guide", "respond"))
        half = 0 if set_name == "bandai1-tune" else 1
        return {
            "locomotion": loco[half::2],
            "dance/fight": dance[half::2],
            "gestures": gest[half::2],
        }
    if set_name == "bandai2":
        loco = _bvh("bandai2", ("walk", "walk-turn-left", "walk-turn-right", "run"))
        gest = _bvh(
            "bandai2",
            ("raise-up-both-hands", "raise-up-left-hand", "raise-up-right-hand",
             "wave-both-hands", "wave-left-hand", "wave-right-hand"),
        )  # fmt: skip
        return {"locomotion": loco, "gestures": gest}
    if set_name == "cmu":
        d = SHARED / "cmu-asfamc"
        return {
            "01 playground": sorted(glob.glob(str(d / "01" / "*.amc"))),
            "03 walking": sorted(glob.glob(str(d / "03" / "*.amc"))),
        }
    raise SystemExit(f"unknown set {set_name!r}")


def load(path: str, seconds: float):
    m = read_motion(path)
    n = m.seconds_to_frames(seconds)
    return m[:n] if m.num_frames > n else m


def glitch_cells(take_path: str, motion, pad_seconds: float = 0.1) -> np.ndarray:
    """(F, J) bool: the listed real glitches of a CMU take (entries judged glitches), dilated by
    ``pad_seconds``; all False for other takes."""
    out = np.zeros((motion.num_frames, motion.num_joints), dtype=bool)
    if not GLITCHES.exists() or not take_path.endswith(".amc"):
        return out
    take = Path(take_path).stem
    names = list(motion.skeleton.names)
    for g in json.loads(GLITCHES.read_text())["glitches"]:
        if g["take"] == take and g["glitch"] and g["joint"] in names:
            a, b = g["frames"]
            if a < motion.num_frames:
                out[a : min(b, motion.num_frames - 1) + 1, names.index(g["joint"])] = True
    pad = max(1, round(pad_seconds * motion.fps))
    return ndimage.binary_dilation(out, structure=np.ones((2 * pad + 1, 1), dtype=bool))


def listed_glitches(take_path: str, motion) -> list[tuple[int, int, int]]:
    """(joint, first, last frame) of the listed glitches of a CMU take within its frames."""
    if not GLITCHES.exists() or not take_path.endswith(".amc"):
        return []
    names = list(motion.skeleton.names)
    out = []
    for g in json.loads(GLITCHES.read_text())["glitches"]:
        a, b = g["frames"]
        if g["take"] == Path(take_path).stem and g["glitch"] and a < motion.num_frames:
            out.append((names.index(g["joint"]), a, min(b, motion.num_frames - 1)))
    return out


def find_glitches(motion, step_deg=30.0, ratio=6.0, sigmas=15.0, window=25, merge=6) -> list:
    """The blind glitch signal (independent of the cleaner): per joint, the frame-to-frame
    rotation angle far above its local median and above ``step_deg``; events within ``merge``
    frames merged. Returns dicts (joint, frames [start, end], peak_step_deg)."""
    from mocapkit.core import rotations as rot
    from mocapkit.core.runs import true_runs

    q = motion.rotations
    sp = np.degrees(rot.quat_angle(q[1:], q[:-1]))
    med = ndimage.median_filter(sp, size=(window, 1), mode="nearest")
    dev = sp - med
    mad = np.median(np.abs(dev), axis=0) + 1e-6
    hot = dev > np.maximum(6.0, sigmas * 1.4826 * mad)[None]
    out = []
    for j in range(q.shape[1]):
        h = ndimage.binary_dilation(hot[:, j], iterations=merge)
        for a, b in true_runs(h):
            pk = int(a + np.argmax(sp[a : b + 1, j]))
            if sp[pk, j] > step_deg and sp[pk, j] > ratio * med[pk, j]:
                out.append(
                    {
                        "joint": motion.skeleton.names[j],
                        "frames": [int(a + merge), int(b - merge + 1)],
                        "peak_step_deg": round(float(sp[pk, j]), 1),
                    }
                )
    return out


def find_excursions(
    motion,
    dev_deg=10.0,
    max_seconds=0.05,
    window_seconds=0.15,
    settle_frac=0.5,
    merge_seconds=0.05,
) -> list:
    """A second blind glitch signal (independent of the cleaner and of ``find_glitches``): short
    out-and-back excursions of a joint's rotation away from its own local trajectory.

    Voluntary human movement has almost no power above ~10 Hz (its spectrum falls off well below
    that; what lies above is tremor of a degree or less and capture noise), so a joint that
    leaves its path by ``dev_deg`` (10 deg) and is back on it within ``max_seconds`` (50 ms, 6
    frames at 120 fps: the out-and-back of a >= 10 Hz component) is not motion a person makes: it
    is a marker swap, an occlusion or a solver pop. Per joint: the local trajectory is the running
    median (componentwise, over sign-continuous quaternions, renormalised) over ``window_seconds``
    (150 ms; a median over w frames ignores any excursion shorter than w/2, so it keeps the path
    through a 6-frame pop); the deviation is the angle between the frame's rotation and that
    median. A candidate is a run of frames deviating more than ``dev_deg``, widened on each side
    while the deviation stays above ``settle_frac`` of ``dev_deg``: the whole excursion, from
    leaving the path to being back on it, must last at most ``max_seconds``, else it is dropped.
    It is kept if it also leaves the *chord* of its own ends: some frame of the widened run lies
    more than ``dev_deg`` from the slerp between the last frame before and the first frame after
    it (this rejects the median's clipping of a fast but smooth turning point, whose frames lie
    on the chord of their neighbours). Events of the same joint at most ``merge_seconds`` apart
    are merged. Returns dicts (joint, frames [start, end] inclusive, peak_dev_deg: the largest
    angle from the chord, in degrees)."""
    from mocapkit.core import rotations as rot
    from mocapkit.core.runs import true_runs

    fps = float(motion.fps)
    q = rot.quat_unroll(np.asarray(motion.rotations, dtype=np.float64), axis=0)
    n = q.shape[0]
    w = max(3, round(window_seconds * fps) | 1)
    med = rot.quat_normalize(ndimage.median_filter(q, size=(w, 1, 1), mode="nearest"))
    dev = np.degrees(rot.quat_angle(q, med))
    longest = max(1, round(max_seconds * fps))
    merge = max(1, round(merge_seconds * fps))
    out = []
    for j in range(q.shape[1]):
        events = []
        for a, b in true_runs(dev[:, j] > dev_deg):
            if b - a + 1 > longest:
                continue
            lo, hi = a, b
            while lo > 0 and dev[lo - 1, j] > settle_frac * dev_deg:
                lo -= 1
            while hi < n - 1 and dev[hi + 1, j] > settle_frac * dev_deg:
                hi += 1
            if lo == 0 or hi == n - 1 or hi - lo + 1 > longest:
                continue  # not out and back within max_seconds, or no frame to come back to
            t = (np.arange(lo, hi + 1) - (lo - 1)) / (hi + 2 - lo)
            chord = rot.quat_slerp(q[lo - 1, j], q[hi + 1, j], t)
            off = np.degrees(rot.quat_angle(q[lo : hi + 1, j], chord))
            if off.max() > dev_deg:
                events.append([lo, hi, float(off.max())])
        merged: list = []
        for ev in events:
            if merged and ev[0] - merged[-1][1] <= merge:
                merged[-1][1] = ev[1]
                merged[-1][2] = max(merged[-1][2], ev[2])
            else:
                merged.append(ev)
        for lo, hi, pk in merged:
            out.append(
                {
                    "joint": motion.skeleton.names[j],
                    "frames": [int(lo), int(hi)],
                    "peak_dev_deg": round(pk, 1),
                }
            )
    return out


def find_holds(motion, min_seconds: float = 0.05) -> list:
    """A third blind glitch signal (independent of the cleaner and of the other two): dropouts,
    stretches where a joint's rotation repeats the same values exactly.

    A captured joint is never still to the file's precision: marker noise moves every solved
    angle by more than the last digit CMU writes (6 decimals of a degree) from one frame to the
    next, so a rotation repeated bit for bit over ``min_seconds`` (50 ms, 6 frames at 120 fps)
    means the solver had no data and held the last value (on the clean Bandai-1 takes, at
    30 fps, no moving joint repeats for more than 3 frames). Only joints that rotate somewhere
    in the take count (a joint the rig never moves repeats all along). Returns dicts (joint,
    frames [first, last] held inclusive, held_frames)."""
    from mocapkit.core.runs import true_runs

    q = np.asarray(motion.rotations)
    same = np.all(q[1:] == q[:-1], axis=-1)  # frame t+1 repeats frame t
    moves = ~np.all(q == q[:1], axis=(0, 2))
    shortest = max(2, round(min_seconds * float(motion.fps)))
    out = []
    for j in np.flatnonzero(moves):
        for a, b in true_runs(same[:, j]):
            if b - a + 2 >= shortest:  # frames a..b+1 identical
                out.append(
                    {
                        "joint": motion.skeleton.names[j],
                        "frames": [int(a), int(b + 1)],
                        "held_frames": int(b - a + 2),
                    }
                )
    return out


def find_jitter(
    motion,
    rms_deg: float = 2.0,
    cutoff_hz: float = 10.0,
    window_seconds: float = 0.1,
    min_seconds: float = 0.05,
    merge_seconds: float = 0.1,
) -> list:
    """A fourth blind glitch signal (independent of the cleaner and of the other three):
    stretches where a joint's rotation is rough, capture noise rather than movement.

    Voluntary human movement has almost no power above ~10 Hz; physiological tremor is a degree
    or less. So what a joint does off its own 10 Hz low-pass path (second-order Butterworth,
    zero phase, componentwise over sign-continuous quaternions, renormalised) is noise, and
    where its RMS over ``window_seconds`` (0.1 s) exceeds ``rms_deg`` (2 deg) for at least
    ``min_seconds`` (50 ms) the joint jitters. ``rms_deg`` was set on the clean Bandai-1 tuning
    half (88 takes at 30 fps, where 10-15 Hz is all the band above the cutoff): 99% of its
    cells stay under 1.6 deg and 0.6% exceed 2 deg, on forearms, hands, feet and toes in fast
    moves. The residual spans 10 Hz to half the frame rate, so the same capture noise reads
    larger at 120 fps (CMU) than at 30 fps, where the threshold was set: at 120 fps the signal
    lists more, and the eye verdicts decide. Runs of a joint at most ``merge_seconds`` apart
    are merged, so a rough stretch is one entry. Only
    joints that rotate somewhere in the take count. Returns dicts (joint, frames [first, last]
    inclusive, peak_rms_deg)."""
    from scipy import signal as sig

    from mocapkit.core.runs import true_runs

    fps = float(motion.fps)
    q = rot.quat_unroll(np.asarray(motion.rotations, dtype=np.float64), axis=0)
    if q.shape[0] < 16:  # too short for the zero-phase filter's padding
        return []
    sos = sig.butter(2, min(cutoff_hz, 0.45 * fps), fs=fps, output="sos")
    smooth = rot.quat_normalize(sig.sosfiltfilt(sos, q, axis=0))
    off = np.degrees(rot.quat_angle(q, smooth))
    w = max(3, round(window_seconds * fps) | 1)
    score = np.sqrt(np.maximum(ndimage.uniform_filter1d(off**2, w, axis=0, mode="nearest"), 0.0))
    moves = ~np.all(q == q[:1], axis=(0, 2))
    gap = max(1, round(merge_seconds * fps))
    shortest = max(1, round(min_seconds * fps))
    out = []
    for j in np.flatnonzero(moves):
        hot = score[:, j] > rms_deg
        hot |= ndimage.binary_closing(hot, structure=np.ones(gap + 1, dtype=bool))
        for a, b in true_runs(hot):
            if b - a + 1 >= shortest:
                out.append(
                    {
                        "joint": motion.skeleton.names[j],
                        "frames": [int(a), int(b)],
                        "peak_rms_deg": round(float(score[a : b + 1, j].max()), 1),
                    }
                )
    return out


def variants(ablate: bool, also: str = "", drops: str = "") -> dict[str, tuple[type, ...]]:
    """The pipelines scored from the same fits: "full" (:data:`PIPELINE`), with ``ablate``
    each rule left out, and with ``also`` ("a,b") the pipeline plus those rules of
    :data:`RETIRED` (what removing them changed); ``drops`` ("a,b;c"): :data:`ORIGINAL_ORDER`
    less each ;-separated set of rules (backward elimination)."""
    out = {"full": PIPELINE}
    if ablate:
        for r in PIPELINE[1:]:
            out[f"-{r.name}"] = tuple(x for x in PIPELINE if x is not r)
    for drop in filter(None, drops.split(";")):
        names = drop.split(",")
        out["orig-" + "-".join(names)] = tuple(r for r in ORIGINAL_ORDER if r.name not in names)
    if also:
        extra = [r for r in RETIRED if r.name in also.split(",")]
        order = [r for r in (*PIPELINE, *RETIRED) if r in PIPELINE or r in extra]
        out["+" + "+".join(r.name for r in extra)] = tuple(
            sorted(order, key=lambda r: ORIGINAL_ORDER.index(r))
        )
    return out


def slide_row(slides: dict, key: tuple, clean, cor, cl) -> None:
    """Foot slide (m/s of planted feet, contacts of the clean take) within 0.5 s of the
    injected errors: clean take, injected take, repaired without and with the foot lock."""
    try:
        contacts = foot_contacts(clean)
    except ValueError:
        return
    near = ndimage.binary_dilation(cor.frames, iterations=clean.seconds_to_frames(0.5))
    plain = cl.repair(foot_lock=False).motion
    locked = cl.repair().motion
    keys = ("clean", "injected", "repaired", "locked", "off_repaired", "off_locked",
            "worst_repaired", "worst_locked", "turn_repaired", "turn_locked")  # fmt: skip
    row = slides.setdefault(key, {k: [] for k in keys})
    for k, m in (
        ("clean", clean),
        ("injected", cor.motion),
        ("repaired", plain),
        ("locked", locked),
    ):
        v = foot_slide(m, contacts, near)
        if np.isfinite(v):
            row[k].append(v)
    # how far the feet end up from the clean take's (cm, mean over the frames near the errors):
    # the lock must not buy its slide by moving the feet away from where they were
    cm = 100.0 * metres_per_unit(clean, None)
    legs = sorted({j for c in leg_chains(clean) for j in c.joints})
    feet = list(contacts.joints)
    p0 = forward_kinematics(clean)[0][near][:, feet]
    for k, m in (("repaired", plain), ("locked", locked)):
        d = np.linalg.norm(forward_kinematics(m)[0][near][:, feet] - p0, axis=-1) * cm
        if d.size == 0:
            continue
        row[f"off_{k}"].append(float(d.mean()))
        # the largest turn of a leg joint away from the clean take's (degrees)
        q = rot.quat_mul(m.rotations[near][:, legs], rot.quat_inv(clean.rotations[near][:, legs]))
        row[f"turn_{k}"].append(
            float(np.degrees(2 * np.arccos(np.clip(np.abs(q[..., 0]), 0, 1))).max())
        )
        row[f"worst_{k}"].append(float(d.max()))


def mp(v: list) -> str:
    """Mean / 95th percentile of ``v``."""
    return f"{np.mean(v):5.1f} / {np.percentile(v, 95):5.1f}" if v else "  -  "


REPAIRS: dict = {}  # (set, class, kind) -> [injected errors, repaired errors] (deg, per cell)


def repair_row(key: tuple, clean, cor, cl) -> None:
    """How far the injected cells are from the clean take's rotations (degrees) in the
    injected take and after the repair (foot lock on): the flagged ones and all of them."""
    truth = cor.truth
    if not truth.any():
        return
    fixed = cl.repair().motion
    flagged = cl.mask() & truth

    def err(m) -> np.ndarray:
        return np.degrees(rot.quat_angle(m.rotations, clean.rotations))

    e_in, e_out = err(cor.motion), err(fixed)
    row = REPAIRS.setdefault(key, {"injected": [], "repaired": [], "flagged_in": [],
                                   "flagged_out": [], "worse": 0, "cells": 0})  # fmt: skip
    row["injected"].extend(e_in[truth].tolist())
    row["repaired"].extend(e_out[truth].tolist())
    row["flagged_in"].extend(e_in[flagged].tolist())
    row["flagged_out"].extend(e_out[flagged].tolist())
    row["worse"] += int((e_out[truth] > e_in[truth] + 1.0).sum())
    row["cells"] += int(truth.sum())


def choose_takes(
    files: list[str], n: int, seconds: float, min_seconds: float = MIN_SECONDS, fps: float = 0.0
) -> tuple[dict, list[str]]:
    """The candidate takes of a class (``4 n`` spread over ``files``, cut to ``seconds``,
    resampled to ``fps`` when given, those of at least ``min_seconds`` kept: {path: motion})
    and the ``n`` spread over them that are evaluated (the others are the small-scale
    context)."""
    takes = {}
    for f in _spread(files, n * 4):
        m = load(f, seconds)
        if fps:
            m = resample(m, fps)
        if m.duration >= min_seconds:
            takes[f] = m
    return takes, _spread(sorted(takes), n)


def evaluate_set(set_name: str, args, table: dict, raw: dict, slides: dict) -> None:
    kinds = args.kinds.split(",")
    vs = variants(args.ablate, args.also, args.drops)
    for cls, files in classes(set_name).items():
        if args.classes and cls not in args.classes:
            continue
        takes, chosen = choose_takes(files, args.takes, args.seconds, args.min_seconds, args.fps)
        table.setdefault((set_name, cls, "n"), len(chosen))
        for ti, f in enumerate(chosen):
            clean = takes[f]
            others = [g for g in sorted(takes) if g != f]
            ctx = [takes[g] for g in _spread(others, args.context_size)]
            act = np.flatnonzero(rotating_joints(clean))
            gl = glitch_cells(f, clean)
            if args.raw and f.endswith(".amc"):
                cl = SelfSimilarityCleaner(config=args.config).fit(clean)
                segs = cl.segments()
                off = [s for s in segs if not gl[s.start : s.end + 1, s.joint_index].any()]
                r = raw.setdefault((set_name, cls), {"minutes": 0.0, "segments": 0, "off": 0})
                r["minutes"] += clean.duration / 60.0
                r["segments"] += len(segs)
                r["off"] += len(off)
                for s in off:
                    r.setdefault("joints", {}).setdefault(s.joint, 0)
                    r["joints"][s.joint] += 1
                    for why in s.reasons:
                        r.setdefault("reasons", {}).setdefault(why, 0)
                        r["reasons"][why] += 1
                # the listed glitches (within the cut) that a flag overlaps
                hit_mask = cl.mask()
                body = body_of(clean)
                for g in listed_glitches(f, clean):
                    j, a, b = g
                    hit = int(hit_mask[a : b + 1, j].any())
                    r["listed"] = r.get("listed", 0) + 1
                    r["listed_hit"] = r.get("listed_hit", 0) + hit
                    # per body segment: toes and thumbs flicker, limbs pop
                    seg = r.setdefault("listed_by_segment", {}).setdefault(
                        body.category(j) or "other", [0, 0]
                    )
                    seg[0] += hit
                    seg[1] += 1
            for ki, kind in enumerate(kinds):
                rng = np.random.default_rng([args.seed, ti, ki, len(cls), len(set_name)])
                cor = corrupt(clean, rng, kinds=[kind], joints=act)
                truth = unit_matrix(cor.truth, clean.fps)[:, act]
                # the listed glitches, and words whose only rewritten frames changed by
                # under a degree (a frozen hold's first frames where the joint barely moved:
                # held, so rightly flagged, yet not in the truth), count neither way
                excused = unit_matrix(gl | cor.rewritten, clean.fps)[:, act] & ~truth
                for ctx_name, c in (("local", []), ("small", ctx)):
                    cl = SelfSimilarityCleaner(config=args.config).fit(cor.motion, c)
                    if args.repair and ctx_name == "local":
                        slide_row(slides, (set_name, cls), clean, cor, cl)
                        repair_row((set_name, cls, kind), clean, cor, cl)
                    for vname, pipe in vs.items():
                        fl = run_pipeline(cl.evidence_, pipeline=pipe)
                        mask = fl.mask
                        flagged = unit_matrix(mask, clean.fps)[:, act] & ~excused
                        for key in ((kind, ctx_name), ("all", ctx_name), ("all", "both")):
                            k = (set_name, cls, vname, *key)
                            table.setdefault(k, Counts()).add(truth, flagged)
                        if vname == "full":
                            false_alarm_reasons(fl, truth, flagged, act, clean.fps,
                                                (set_name, cls, ctx_name, kind))  # fmt: skip
                            if args.misses:
                                print_misses(f, cor, truth & ~flagged, act, clean, ctx_name)
            print(
                f"  [{time.time() - T0:6.0f} s] {set_name} / {cls}: {Path(f).name}",
                file=sys.stderr,
                flush=True,
            )


def print_misses(path: str, cor, missed: np.ndarray, act, motion, ctx_name: str) -> None:
    """One line per missed (joint, word) unit, with the injected error it belongs to."""
    starts, n = unit_words(motion.num_frames, motion.fps)
    for w, ja in zip(*np.nonzero(missed), strict=True):
        j = int(act[ja])
        a, b = int(starts[w]), int(starts[w] + n)
        name = motion.skeleton.names[j]
        errs = [e for e in cor.spans() if e[1] == name and e[2] < b and e[3] >= a]
        print(
            f"  MISS {Path(path).name} {ctx_name} {motion.skeleton.names[j]} word {a}:{b} "
            f"of {motion.num_frames}: {errs}",
            file=sys.stderr,
        )


REASONS: dict = {}  # (set, class, context, kind) -> {rule: false-alarm units it flagged}


def false_alarm_reasons(fl, truth, flagged, act, fps, key) -> None:
    """Count the false-alarm units (flagged, not injected, not excused) each rule flagged
    (a unit with cells of two rules counts for both)."""
    false = flagged & ~truth
    row = REASONS.setdefault(key, {"units": 0})
    row["units"] += int(false.sum())
    for rule, cells in fl.added.items():
        n = int((unit_matrix(cells & fl.mask, fps)[:, act] & false).sum())
        if n:
            row[rule] = row.get(rule, 0) + n


def fmt(c: Counts) -> str:
    r = "  -  " if np.isnan(c.recall) else f"{c.recall:.3f}"
    p = "  -  " if np.isnan(c.precision) else f"{c.precision:.3f}"
    return f"{r}/{p}"


T0 = time.time()


def parse_config(text: str) -> DetectConfig:
    """``DetectConfig`` with ``field=value,...`` changes (true/false, else a number)."""
    changes: dict = {}
    for item in filter(None, text.split(",")):
        key, _, val = item.partition("=")
        low = val.strip().lower()
        changes[key.strip()] = low == "true" if low in ("true", "false") else float(val)
    return DetectConfig().replace(**changes)


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--set", dest="sets", action="append", default=None)
    ap.add_argument(
        "--class",
        dest="classes",
        action="append",
        default=None,
        help="only this motion class (repeatable)",
    )
    ap.add_argument("--takes", type=int, default=4, help="takes per class")
    ap.add_argument("--seconds", type=float, default=20.0, help="takes cut to this long")
    ap.add_argument(
        "--fps", type=float, default=0.0,
        help="resample every take to this rate first (Bandai-1 at 120 fps: CMU's rate)",
    )  # fmt: skip
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument(
        "--min-seconds", type=float, default=MIN_SECONDS,
        help="leave out takes shorter than this (a local context needs a few seconds)",
    )  # fmt: skip
    ap.add_argument("--kinds", default=",".join(ERROR_KINDS))
    ap.add_argument("--context-size", type=int, default=3, help="small-scale context takes")
    ap.add_argument("--ablate", action="store_true", help="also the pipeline without each rule")
    ap.add_argument("--raw", action="store_true", help="CMU: also the uninjected takes")
    ap.add_argument("--also", default="", help="score PIPELINE plus these retired rules too")
    ap.add_argument("--drops", default="", help="score ORIGINAL_ORDER less these: 'a,b;c'")
    ap.add_argument("--repair", action="store_true", help="foot slide before/after repair")
    ap.add_argument("--misses", action="store_true", help="print every missed unit (stderr)")
    ap.add_argument("--json", default=None, help="write the figures here too")
    ap.add_argument(
        "--config", default="",
        help="DetectConfig changes, 'field=value,...' (numbers; true/false for switches)",
    )  # fmt: skip
    args = ap.parse_args()
    args.config = parse_config(args.config)
    if not SHARED.exists():
        print(f"shared data not found at {SHARED}", file=sys.stderr)
        return 2
    sets = args.sets or ["bandai1-tune"]
    table: dict = {}
    raw: dict = {}
    slides: dict = {}
    for s in sets:
        evaluate_set(s, args, table, raw, slides)
    kinds = [*args.kinds.split(","), "all"]
    out: dict = {"detection": [], "ablation": [], "raw": [], "foot_slide": []}
    print("\nDetection, (joint, source-word) units: recall/precision (targets 0.98/0.93)")
    print(f"{'set':13s} {'class':14s} {'takes':>5s} " + " ".join(f"{k:>13s}" for k in kinds))
    for s in sets:
        for cls in classes(s):
            if args.classes and cls not in args.classes:
                continue
            n = table.get((s, cls, "n"), 0)
            for ctx in ("local", "small"):
                row = f"{s:13s} {cls + ' ' + ctx:14s} {n:5d} "
                for k in kinds:
                    c = table.get((s, cls, "full", k, ctx), Counts())
                    row += f" {fmt(c):>13s}"
                    out["detection"].append(
                        {"set": s, "class": cls, "takes": n, "context": ctx, "kind": k,
                         "recall": None if np.isnan(c.recall) else c.recall,
                         "precision": None if np.isnan(c.precision) else c.precision,
                         "tp": c.tp, "fp": c.fp, "fn": c.fn}
                    )  # fmt: skip
                print(row)
    if args.ablate:
        print("\nAblation (all kinds, both contexts): recall/precision without each rule")
        for s in sets:
            tot = {}
            for (s2, _cls, v, k, ctx), c in ((k, v) for k, v in table.items() if len(k) == 5):
                if s2 == s and k == "all" and ctx == "both":
                    t = tot.setdefault(v, Counts())
                    t.tp, t.fp, t.fn = t.tp + c.tp, t.fp + c.fp, t.fn + c.fn
            full = tot.get("full", Counts())
            for v, c in sorted(tot.items()):
                dr, dp = c.recall - full.recall, c.precision - full.precision
                print(f"  {s:13s} {v:20s} {fmt(c)}   d-recall {dr:+.4f}  d-precision {dp:+.4f}")
                out["ablation"].append(
                    {"set": s, "variant": v, "recall": c.recall, "precision": c.precision,
                     "d_recall": dr, "d_precision": dp, "tp": c.tp, "fp": c.fp, "fn": c.fn}
                )  # fmt: skip
    print("\nFalse-alarm units per rule that flagged them (all kinds; a unit may count twice)")
    agg: dict = {}
    for (s, cls, ctx, kind), row in REASONS.items():
        out.setdefault("false_alarm_reasons", []).append(
            {"set": s, "class": cls, "context": ctx, "kind": kind, **row}
        )
        a = agg.setdefault((s, cls, ctx), {})
        for rule, n in row.items():
            a[rule] = a.get(rule, 0) + n
    for (s, cls, ctx), a in agg.items():
        rules = ", ".join(
            f"{r} {n}" for r, n in sorted(a.items(), key=lambda x: -x[1]) if r != "units"
        )
        print(f"  {s:13s} {cls + ' ' + ctx:20s} {a['units']:5d} units: {rules}")
    if raw:
        print("\nUninjected raw takes: flagged segments, off the glitch list, per minute")
        for (s, cls), r in raw.items():
            per = r["off"] / max(r["minutes"], 1e-9)
            segs = sorted(r.get("listed_by_segment", {}).items())
            by_seg = ", ".join(f"{k} {h}/{n}" for k, (h, n) in segs)
            print(
                f"  {s} {cls}: {r['minutes']:.1f} min, {r['segments']} segments, {r['off']} off "
                f"the list ({per:.1f}/min); listed glitches flagged "
                f"{r.get('listed_hit', 0)}/{r.get('listed', 0)} (by body segment: "
                f"{by_seg}); off-list by joint "
                f"{r.get('joints', {})}; off-list by rule {r.get('reasons', {})}"
            )
            out["raw"].append({"set": s, "class": cls, **r})
    if slides:
        print("\nFoot slide of planted feet (clean take's contacts) within 0.5 s of the errors,")
        print("m/s, mean over takes x kinds (local context): clean / injected / repaired / +lock;")
        print("feet off the clean take's (cm near the errors, mean; worst): repaired / +lock;")
        print("largest turn of a leg joint off the clean take's (deg): repaired / +lock")
        for (s, cls), r in slides.items():
            vals = {k: float(np.mean(v)) if v else float("nan") for k, v in r.items()}
            print(
                f"  {s:13s} {cls:14s} n={len(r['clean']):3d}  {vals['clean']:.3f} / "
                f"{vals['injected']:.3f} / {vals['repaired']:.3f} / {vals['locked']:.3f};  "
                f"{vals['off_repaired']:.2f} / {vals['off_locked']:.2f} cm; "
                f"{vals['worst_repaired']:.1f} / {vals['worst_locked']:.1f} cm; leg turn "
                f"{vals['turn_repaired']:.1f} / {vals['turn_locked']:.1f} deg"
            )
            out["foot_slide"].append({"set": s, "class": cls, "n": len(r["clean"]), **vals})
    if REPAIRS:
        print(
            "\nRepair: injected cells' angle from the clean take (deg, mean / 95th pct): "
            "injected -> repaired; the flagged ones; cells repaired worse by over 1 deg"
        )
        for (s, cls, kind), r in sorted(REPAIRS.items()):
            print(
                f"  {s:13s} {cls:14s} {kind:7s} all {mp(r['injected'])} -> {mp(r['repaired'])};"
                f" flagged {mp(r['flagged_in'])} -> {mp(r['flagged_out'])};"
                f" worse {r['worse']}/{r['cells']}"
            )
            out.setdefault("repair", []).append(
                {"set": s, "class": cls, "kind": kind, "cells": r["cells"], "worse": r["worse"],
                 **{k: float(np.mean(r[k])) if r[k] else None
                    for k in ("injected", "repaired", "flagged_in", "flagged_out")}}
            )  # fmt: skip
    print(f"\n{time.time() - T0:.0f} s")
    if args.json:
        out["config"] = args.config.as_dict()
        Path(args.json).write_text(json.dumps(out, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
