"""Foot skate of the transitions chosen by each comparison metric (the paper's Table 1), on the
Bandai-Namco clips: fighting (kick, punch, slash, dance) and locomotion (walk, run).

    PYTHONPATH=src python bench/eval_graph.py [--data ../shared/data/bandai1/data] [--T 67]

For each set the three metrics select the same number T of transitions, the T cheapest (T from
the knee rule on the dynamics metric unless --T is given; not the default build's connections,
which differ per metric); the table gives the mean start-to-end distance and arc length (cm) of
the supporting foot over the blended transitions.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from mocapkit.graph.graph import build_graph
from mocapkit.graph.skate import transition_skate
from mocapkit.io import read_motion

SETS = {
    "fighting": ("kick", "punch", "slash", "dance-short", "dance-long"),
    "locomotion": ("walk", "run"),
}


def clips_of(data: Path, kinds: tuple[str, ...]) -> list[Path]:
    out = []
    for p in sorted(data.glob("*.bvh")):
        kind = p.stem.split("_")[1]
        if kind in kinds:
            out.append(p)
    return out


def main() -> int:
    ap = argparse.ArgumentParser()
    here = Path(__file__).resolve().parent.parent
    ap.add_argument("--data", default=str(here.parent / "shared" / "data" / "bandai1" / "data"))
    ap.add_argument("--T", type=int, default=None)
    ap.add_argument("--window", type=float, default=1.0 / 3.0)
    ap.add_argument("--json", default=None)
    ap.add_argument("--sets", default="fighting,locomotion")
    ap.add_argument("--plots", default=None, help="Folder for the Figure 3/4 style plots.")
    args = ap.parse_args()
    data = Path(args.data)
    results = {}
    for name in args.sets.split(","):
        paths = clips_of(data, SETS[name])
        motions = [read_motion(p) for p in paths]
        frames = sum(m.num_frames for m in motions)
        graphs = {}
        dbs = {}
        T = args.T
        if T is None:  # the knee rule's T on the dynamics metric, then exactly T for all three
            T = build_graph(motions, "dynamics", window=args.window)[0].T
        for metric in ("dynamics", "uniform", "torso"):
            t0 = time.perf_counter()
            g, db, _ = build_graph(
                motions, metric, paths=[str(p) for p in paths], window=args.window, transitions=T
            )
            graphs[metric] = (g, time.perf_counter() - t0)
            dbs[metric] = db
        row = {"clips": len(paths), "frames": frames, "T": T}
        for metric, (g, secs) in graphs.items():
            rep = transition_skate(g, motions).summary()
            row[metric] = {"seconds": secs, **rep}
        results[name] = row
        print(f"\n{name}: {len(paths)} clips, {frames} frames, T = {T}")
        print(
            f"  {'metric':10s} {'start-to-end':>13s} {'arc length':>11s} {'(median)':>9s}"
            f" {'supported':>9s}"
        )
        for metric in ("dynamics", "uniform", "torso"):
            r = row[metric]
            print(
                f"  {metric:10s} {r['start_to_end_cm']['mean']:13.2f} "
                f"{r['arc_length_cm']['mean']:11.2f} {r['arc_length_cm']['median']:9.2f} "
                f"{r['supported']:5d}/{r['transitions']}"
            )
        sys.stdout.flush()
        if args.plots:
            from mocapkit.graph.graph import cost_comparison
            from mocapkit.viz.figures.graph import plot_cost_comparison

            Path(args.plots).mkdir(parents=True, exist_ok=True)
            for other in ("uniform", "torso"):
                cmp = cost_comparison(
                    {"dynamics": dbs["dynamics"], other: dbs[other]},
                    {"dynamics": graphs["dynamics"][0], other: graphs[other][0]},
                )
                p = plot_cost_comparison(
                    cmp,
                    Path(args.plots) / f"costs_{name}_dynamics_vs_{other}.png",
                    title=f"{name}: dynamics vs {other} metric, T = {T}",
                )
                print(f"  wrote {p}")
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
