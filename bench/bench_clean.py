"""Speed of mocapkit.clean: a 15 s take against contexts of 0..30 takes of 15 s, in one run.

Prints the wall time of ``SelfSimilarityCleaner.fit`` (all five joint groups, K = 5) and of
``mask()`` (the detection rules: evidence computed once, then the pipeline) for each context
size, at the take's rate (``--fps``, 30 by default; 120 as the CMU captures), the time per
million context frames x source words (which should stay flat if the
cost grows linearly with the context), the two-stage mode, and the published figures for
reference (MATLAB, 6-core i7: 2 min local, 20 min small-scale, 90 min large-scale per 15 s take).

    PYTHONPATH=src .venv/bin/python bench/bench_clean.py [--takes 30] [--seconds 15] [--fps 120]

The script uses only ``fit`` and ``mask``, so the same file times an older tree in the same
session (``git archive <commit> src | tar -x -C old; PYTHONPATH=old/src python
bench/bench_clean.py``): issue #16 compares the declared pipeline with the rules it replaced.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from mocapkit import datasets
from mocapkit.clean import SelfSimilarityCleaner, inject


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--takes", type=int, default=30)
    ap.add_argument("--seconds", type=float, default=15.0)
    ap.add_argument("--sizes", default="0,5,10,20,30")
    ap.add_argument("--fps", type=float, default=30.0, help="frame rate of the takes")
    args = ap.parse_args()
    kinds = ("walk", "run", "wave", "idle")
    import mocapkit

    print(f"mocapkit from {os.path.dirname(mocapkit.__file__)}")
    take = datasets.procedural_motion("walk", seconds=args.seconds, fps=args.fps, seed=100).motion
    rng = np.random.default_rng(0)
    names = list(take.skeleton.names)
    take = inject(
        take, "offset", names.index("LeftForeArm"), rng, start=take.seconds_to_frames(4.0)
    ).motion
    ctx = [
        datasets.procedural_motion(
            kinds[i % 4], seconds=args.seconds, fps=args.fps, seed=200 + i
        ).motion
        for i in range(args.takes)
    ]
    threads = os.environ.get("NUMBA_NUM_THREADS") or str(os.cpu_count())
    print(
        f"take: {args.seconds:g} s at {take.fps:g} fps ({take.num_frames} frames), "
        f"context takes of {args.seconds:g} s; {threads} threads"
    )
    # warm-up (numba compilation / cache load)
    n = take.seconds_to_frames(2.0)
    SelfSimilarityCleaner().fit(take[:n], [ctx[0][:n]])
    sizes = [int(s) for s in args.sizes.split(",") if int(s) <= args.takes]
    rows = []
    for n in sizes:
        c = ctx[:n]
        t0 = time.perf_counter()
        cl = SelfSimilarityCleaner().fit(take, c)
        dt = time.perf_counter() - t0
        t1 = time.perf_counter()
        cl.mask()  # the detection rules on the maps (steps, pairs, spikes, vetoes)
        dm = time.perf_counter() - t1
        frames = cl.texture_.num_frames + sum(round(m.duration * 24) for m in c)
        words = len(cl.starts_)
        rows.append((n, frames, dt + dm, dt / (frames * words) * 1e6, dm))
    print(
        f"\n{'context':>8s} {'ctx frames@24':>14s} {'fit+mask (s)':>13s} {'mask (s)':>9s} "
        f"{'us/(frame*word)':>16s}"
    )
    for n, frames, dt, per, dm in rows:
        print(f"{n:8d} {frames:14d} {dt:13.2f} {dm:9.3f} {per:16.3f}")
    if len(rows) >= 2:
        (n0, f0, t0_, _, _), (n1, f1, t1, _, _) = rows[1] if len(rows) > 2 else rows[0], rows[-1]
        print(
            f"\nscaling {n0}->{n1} takes: context x{f1 / f0:.2f}, time x{t1 / t0_:.2f} "
            "(linear: equal ratios)"
        )
    n = sizes[-1]
    t0 = time.perf_counter()
    SelfSimilarityCleaner(two_stage=True).fit(take, ctx[:n]).mask()
    dt2 = time.perf_counter() - t0
    full = rows[-1][2]
    print(f"two-stage, {n}-take context: {dt2:.2f} s fit+mask (full search {full:.2f} s)")
    target = "MET" if full <= 10.0 else "MISSED"
    print(
        f"\ntarget <= 10 s for a {args.seconds:g} s take with a {n}-take context: "
        f"{full:.2f} s full search ({target}), {dt2:.2f} s two-stage"
    )
    print("published (MATLAB, per 15 s take): local 120 s, small-scale 1200 s, large-scale 5400 s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
