"""Motion-graph scale benchmark: the full graph of a clip library in one run, and how walkable
it is.

    PYTHONPATH=src python bench/bench_graph.py [--data ../shared/data/bandai2/data]
        [--metric dynamics] [--stride N] [--limit CLIPS] [--half even|odd] [--json]

Reads every BVH of the folder, builds the cost database (point clouds, contacts, weights),
finds the local minima of the aligned window cost over all frame pairs in tiles (matrix
products, float32, stride grid; each tile reduced to the library's cheapest minima and every
half-second piece's cheapest partner clips), re-scores the candidates exactly (float64), and
selects the transitions with the default rule (the knee, every clip's ends, bridges; see
:func:`mocapkit.graph.select.select_connected`), refined at full resolution, pruned to the
largest strongly connected component. Prints the wall time of each phase, the peak memory
(resident set size), and the GFLOP/s achieved by the tiles next to numpy's own matrix-multiply
peak measured on this machine with the same dtype (a square product, best of a few).

Then what a user gets: per class (locomotion / gestures: from the Bandai ``.json`` labels and
``cfg/content_label.txt``, else from the content words of the file names), the share of the
frames in the component and the mean start-to-end foot skate (cm, the measure of
``mocapkit graph report``) of the component's transitions (by source clip), next to the same
for the knee rule alone (the T cheapest, the rule before connections) on the same minima; and
the duplicate or overlapping takes found. Targets on all of Bandai-Namco set 2 (~96,000 frames):
<= 10 minutes, <= 2 GB, tiles >= 70 % of numpy's peak, >= 60 % of each class's frames in the
component with a foot skate within 1.2 x the knee rule's mean over all its transitions.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import resource
import sys
import time
from pathlib import Path

import numpy as np

REPO_ROOT = Path(__file__).resolve().parent.parent

#: Content words that make a clip locomotion (the rest are gestures / actions).
LOCOMOTION_WORDS = ("walk", "run", "dash", "jog", "turn", "step", "locomotion")


def default_data_dir() -> Path:
    env = os.environ.get("MOCAPKIT_SHARED")
    root = Path(env).expanduser() if env else REPO_ROOT.parent / "shared"
    return root / "data" / "bandai2" / "data"


def matmul_peak(dtype: type, n: int = 2048, repeats: int = 4) -> float:
    """numpy's matrix-multiply GFLOP/s on this machine (best of ``repeats``)."""
    rng = np.random.default_rng(0)
    a = rng.standard_normal((n, n)).astype(dtype)
    b = rng.standard_normal((n, n)).astype(dtype)
    a @ b
    best = np.inf
    for _ in range(repeats):
        t = time.perf_counter()
        a @ b
        best = min(best, time.perf_counter() - t)
    return 2.0 * n**3 / best / 1e9


def peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def content_of(path: Path) -> str:
    """The clip's content name: the Bandai ``.json`` label's ``content`` looked up in
    ``../cfg/content_label.txt``, else the file name's content words (``dataset-2_walk-turn-
    left_normal_001`` -> ``walk-turn-left``; other names: the name without digits)."""
    label = path.with_suffix(".json")
    names = path.parent.parent / "cfg" / "content_label.txt"
    if label.exists() and names.exists():
        try:
            k = int(json.loads(label.read_text())["content"])
            return names.read_text().split()[k].split("_", 1)[-1]
        except (ValueError, KeyError, IndexError, TypeError):
            pass
    parts = path.stem.split("_")
    if len(parts) >= 3 and parts[0].startswith("dataset"):
        return parts[1]
    return re.sub(r"[\d_]+", " ", path.stem).strip()


def class_of(path: Path) -> str:
    c = content_of(path).lower()
    return "locomotion" if any(w in c for w in LOCOMOTION_WORDS) else "gestures"


def per_class(g, skate, classes: np.ndarray, raw=None) -> dict:
    """Coverage and SCC foot skate (mean start-to-end over supported transitions, by source
    clip) per class, and the mean over all the graph's transitions; ``raw``: the same skate
    without foot locking (the blend alone)."""
    cov = g.coverage()
    out = {}
    for c in sorted(set(classes.tolist())):
        m = classes == c
        src = (classes[g.src_clip] == c) & skate.supported
        scc = src & g.in_scc
        if raw is not None:
            out.setdefault("raw", {})[c] = {
                "skate_scc_cm": float(raw.start_to_end[scc].mean()) if scc.any() else None,
                "skate_all_cm": float(raw.start_to_end[src].mean()) if src.any() else None,
            }
        out[c] = {
            "clips": int(m.sum()),
            "frames": int(cov.frames[m].sum()),
            "frames_in_scc": int(cov.in_scc[m].sum()),
            "coverage": float(cov.in_scc[m].sum() / max(cov.frames[m].sum(), 1)),
            "clips_unreached": int((cov.in_scc[m] == 0).sum()),
            "skate_scc_cm": float(skate.start_to_end[scc].mean()) if scc.any() else None,
            "transitions_scc": int(scc.sum()),
            "skate_all_cm": float(skate.start_to_end[src].mean()) if src.any() else None,
            "transitions_all": int(src.sum()),
        }
    return out


def main() -> int:
    try:
        import mocapkit  # noqa: F401
    except ImportError:
        sys.path.insert(0, str(REPO_ROOT / "src"))
    import mocapkit.graph.graph as gg
    from mocapkit.graph.distance import build_database, tiled_local_minima
    from mocapkit.graph.graph import build_graph, default_stride
    from mocapkit.graph.skate import transition_skate
    from mocapkit.io import read_motion

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", default=str(default_data_dir()))
    ap.add_argument("--metric", default="dynamics")
    ap.add_argument("--stride", type=int, default=None)
    ap.add_argument("--tile", type=int, default=1024)
    ap.add_argument("--limit", type=int, default=None, help="Use the first N clips only.")
    ap.add_argument(
        "--half", choices=("even", "odd"), default=None,
        help="Only the even- or odd-numbered clips of the sorted list (the tuning / report "
        "halves).",
    )  # fmt: skip
    ap.add_argument("--no-knee", action="store_true", help="Skip the knee-only comparison.")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    data = Path(args.data)
    files = sorted(data.glob("*.bvh"))
    if args.half:
        files = files[0 if args.half == "even" else 1 :: 2]
    files = files[: args.limit]
    if not files:
        print(f"no BVH files in {data}", file=sys.stderr)
        return 2
    classes = np.array([class_of(f) for f in files])
    out: dict = {"data": str(data), "clips": len(files), "metric": args.metric}
    if args.half:
        out["half"] = args.half
    t_all = time.perf_counter()

    peak32 = matmul_peak(np.float32)
    peak64 = matmul_peak(np.float64)
    out["numpy_matmul_gflops"] = {"float32": peak32, "float64": peak64}

    t = time.perf_counter()
    motions = [read_motion(f) for f in files]
    out["read_s"] = time.perf_counter() - t
    frames = sum(m.num_frames for m in motions)
    out["frames"] = frames

    t = time.perf_counter()
    db = build_database(motions, args.metric)
    out["database_s"] = time.perf_counter() - t
    stride = default_stride(frames) if args.stride is None else args.stride
    dtype = np.float64 if frames <= 20000 else np.float32
    out["stride"] = stride
    out["dtype"] = np.dtype(dtype).name

    t_build = time.perf_counter()
    minima = tiled_local_minima(db, stride, args.tile, dtype)
    out["tiles_s"] = minima.seconds
    out["pairs_evaluated"] = minima.pairs
    out["minima_kept"] = len(minima.cost)
    out["tile_gflop"] = minima.flops / 1e9
    out["tile_gflops_per_s"] = minima.flops / 1e9 / minima.seconds
    peak = peak32 if dtype == np.float32 else peak64
    out["fraction_of_numpy_peak"] = out["tile_gflops_per_s"] / peak
    # the rest of the pipeline (rescoring, selection, refinement, SCC) on these minima
    _tiled = gg.tiled_local_minima

    def reuse(*a, **k):
        return minima

    gg.tiled_local_minima = reuse
    paths = [str(f) for f in files]
    try:
        g, _, _ = build_graph(
            motions, args.metric, paths=paths, stride=stride, dtype=dtype, database=db
        )
        out["select_s"] = time.perf_counter() - t_build - minima.seconds
        out["build_s"] = time.perf_counter() - t_build
        out["total_s"] = time.perf_counter() - t_all
        out["peak_rss_mb"] = peak_rss_mb()
        knee = None
        if not args.no_knee:  # the knee rule alone (the T cheapest), on the same minima
            t = time.perf_counter()
            knee, _, _ = build_graph(
                motions, args.metric, paths=paths, transitions=g.T, stride=stride,
                dtype=dtype, database=db,
            )  # fmt: skip
            out["knee_select_s"] = time.perf_counter() - t
    finally:
        gg.tiled_local_minima = _tiled
    out["candidates"] = g.stats["candidates"]
    out["T"] = g.T
    out["selection"] = g.stats["selection"]
    out["transitions"] = g.num_transitions
    out["transitions_in_scc"] = int(g.in_scc.sum())
    out["scc_frames"] = g.scc_frames()
    cov = g.coverage()
    out["coverage"] = cov.fraction
    out["overlaps"] = g.stats["overlaps"]
    t = time.perf_counter()
    sk = transition_skate(g, motions)
    raw = transition_skate(g, motions, foot_lock=False)
    out["classes"] = per_class(g, sk, classes, raw)
    out["raw"] = out["classes"].pop("raw")
    out["skate_all_cm"] = {"locked": float(np.nanmean(sk.start_to_end)),
                           "raw": float(np.nanmean(raw.start_to_end))}  # fmt: skip
    if knee is not None:
        ksk = transition_skate(knee, motions)
        kraw = transition_skate(knee, motions, foot_lock=False)
        kc = per_class(knee, ksk, classes, kraw)
        out["knee"] = {
            "transitions": knee.num_transitions,
            "transitions_in_scc": int(knee.in_scc.sum()),
            "coverage": knee.coverage().fraction,
            "raw": kc.pop("raw"),
            "classes": kc,
            "skate_all_cm": {"locked": float(np.nanmean(ksk.start_to_end)),
                             "raw": float(np.nanmean(kraw.start_to_end))},
        }  # fmt: skip
    out["skate_s"] = time.perf_counter() - t
    out["warning"] = cov.warning()
    if args.json:
        print(json.dumps(out, indent=2))
        return 0
    print(f"motion graph of {out['clips']} clips, {frames} frames ({data})")
    print(f"  numpy matmul peak here: {peak32:.1f} GFLOP/s float32, {peak64:.1f} float64")
    print(
        f"  read {out['read_s']:.1f} s; database (FK, contacts, weights) {out['database_s']:.1f} s"
    )
    print(
        f"  tiles: stride {stride}, {out['dtype']}, {minima.pairs:.3g} pairs, "
        f"{out['tile_gflop']:.0f} GFLOP in {minima.seconds:.1f} s = "
        f"{out['tile_gflops_per_s']:.1f} GFLOP/s ({100 * out['fraction_of_numpy_peak']:.0f}% "
        f"of numpy's {peak:.1f}); {out['minima_kept']} minima kept"
    )
    s = out["selection"]
    print(
        f"  selection (exact re-scoring, overlaps, knee, ends, bridges, refinement, SCC): "
        f"{out['select_s']:.1f} s; {out['candidates']} candidates, T = {g.T}; "
        f"{g.num_transitions} transitions ({s['knee']} knee, {s['end']} ends, {s['bridge']} "
        f"bridges: {s['components_bridged']} components joined, {s['components_left_out']} "
        f"left out), {out['transitions_in_scc']} in the SCC ({out['scc_frames']} frames)"
    )
    print(
        f"  build {out['build_s']:.1f} s, total {out['total_s']:.1f} s (target 600), peak memory "
        f"{out['peak_rss_mb']:.0f} MB (target 2048)"
    )
    print(f"  {cov.summary()}")
    hdr = f"  {'class':11s} {'clips':>5s} {'frames':>7s}  {'coverage':>8s}  {'skate SCC':>9s}"
    print(hdr + f" {'(n)':>6s}   knee rule: {'coverage':>8s} {'skate all':>9s} {'(n)':>6s}")
    for c, r in out["classes"].items():
        k = out.get("knee", {}).get("classes", {}).get(c)
        sc = f"{r['skate_scc_cm']:.2f}" if r["skate_scc_cm"] is not None else "-"
        line = (
            f"  {c:11s} {r['clips']:5d} {r['frames']:7d}  {100 * r['coverage']:7.1f}%  "
            f"{sc:>9s} {r['transitions_scc']:6d}"
        )
        if k:
            ka = f"{k['skate_all_cm']:.2f}" if k["skate_all_cm"] is not None else "-"
            ratio = (
                f"  ({r['skate_scc_cm'] / k['skate_all_cm']:.2f}x)"
                if r["skate_scc_cm"] is not None and k["skate_all_cm"]
                else ""
            )
            line += (
                f"              {100 * k['coverage']:7.1f}% {ka:>9s} {k['transitions_all']:6d}"
                f"{ratio}"
            )
        print(line)
    print("  the same without foot locking (the blend alone, as synthesis rendered before):")
    for c, r in out["raw"].items():
        k = out.get("knee", {}).get("raw", {}).get(c, {})
        fmt = lambda v: f"{v:.2f}" if v is not None else "-"  # noqa: E731
        print(f"  {c:11s} skate SCC {fmt(r['skate_scc_cm']):>6s} cm; knee rule: skate all "
              f"{fmt(k.get('skate_all_cm')):>6s} cm")  # fmt: skip
    a = out["skate_all_cm"]
    ka = out.get("knee", {}).get("skate_all_cm")
    print(
        f"  mean over all transitions: {a['locked']:.2f} cm locked, {a['raw']:.2f} cm raw"
        + (f"; knee rule {ka['locked']:.2f} cm locked, {ka['raw']:.2f} cm raw" if ka else "")
    )
    if out["warning"]:
        print(f"  warning: {out['warning']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
