"""Motion-graph scale benchmark: the full graph of a clip library in one run.

    PYTHONPATH=src python bench/bench_graph.py [--data ../shared/data/bandai2/data]
        [--metric dynamics] [--stride N] [--limit CLIPS] [--json]

Reads every BVH of the folder, builds the cost database (point clouds, contacts, weights),
finds the local minima of the aligned window cost over all frame pairs in tiles (matrix
products, float32, stride grid), re-scores the candidates exactly (float64), merges, chooses T by
the knee rule, refines the chosen transitions at full resolution and prunes to the largest
strongly connected component. Prints the wall time of each phase, the peak memory (resident set
size), and the GFLOP/s achieved by the tiles next to numpy's own matrix-multiply peak measured
on this machine with the same dtype (a square product, best of a few). Target: <= 10 minutes and
<= 4 GB for ~96,000 frames (Bandai-Namco set 2).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import sys
import time
from pathlib import Path

import numpy as np

REPO_ROOT = Path(__file__).resolve().parent.parent


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


def main() -> int:
    try:
        import mocapkit  # noqa: F401
    except ImportError:
        sys.path.insert(0, str(REPO_ROOT / "src"))
    from mocapkit.graph.distance import build_database, tiled_local_minima
    from mocapkit.graph.graph import build_graph, default_stride
    from mocapkit.io import read_motion

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", default=str(default_data_dir()))
    ap.add_argument("--metric", default="dynamics")
    ap.add_argument("--stride", type=int, default=None)
    ap.add_argument("--tile", type=int, default=1024)
    ap.add_argument("--limit", type=int, default=None, help="Use the first N clips only.")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    data = Path(args.data)
    files = sorted(data.glob("*.bvh"))[: args.limit]
    if not files:
        print(f"no BVH files in {data}", file=sys.stderr)
        return 2
    out: dict = {"data": str(data), "clips": len(files), "metric": args.metric}
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
    out["tile_gflop"] = minima.flops / 1e9
    out["tile_gflops_per_s"] = minima.flops / 1e9 / minima.seconds
    peak = peak32 if dtype == np.float32 else peak64
    out["fraction_of_numpy_peak"] = out["tile_gflops_per_s"] / peak
    # the rest of the pipeline (rescoring, merging, knee, refinement, SCC) on these minima
    _tiled = tiled_local_minima

    def reuse(*a, **k):
        return minima

    import mocapkit.graph.graph as gg

    gg.tiled_local_minima = reuse
    try:
        g, _, _ = build_graph(motions, args.metric, stride=stride, dtype=dtype, database=db)
        out["select_s"] = time.perf_counter() - t_build - minima.seconds
        # a denser graph for synthesis: 10 x the knee's T (same minima)
        t = time.perf_counter()
        g10, _, _ = build_graph(
            motions, args.metric, transitions=10 * g.T, stride=stride, dtype=dtype, database=db
        )
        out["dense"] = {
            "T": 10 * g.T,
            "transitions": g10.num_transitions,
            "transitions_in_scc": int(g10.in_scc.sum()),
            "scc_frames": g10.scc_frames(),
            "select_s": time.perf_counter() - t,
        }
    finally:
        gg.tiled_local_minima = _tiled
    out["candidates"] = g.stats["candidates"]
    out["T"] = g.T
    out["transitions"] = g.num_transitions
    out["transitions_in_scc"] = int(g.in_scc.sum())
    out["scc_frames"] = g.scc_frames()
    out["total_s"] = time.perf_counter() - t_all - out["dense"]["select_s"]
    out["peak_rss_mb"] = peak_rss_mb()
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
        f"of numpy's {peak:.1f})"
    )
    print(
        f"  selection (exact re-scoring, merging, knee, refinement, SCC): "
        f"{out['select_s']:.1f} s; {out['candidates']} candidates, T = {g.T}, "
        f"{g.num_transitions} transitions, {out['transitions_in_scc']} in the SCC "
        f"({out['scc_frames']} frames)"
    )
    d = out["dense"]
    print(
        f"  (not in the total) with T = {d['T']} (10 x the knee): {d['transitions']} "
        f"transitions, {d['transitions_in_scc']} in the SCC ({d['scc_frames']} frames), "
        f"selection {d['select_s']:.1f} s"
    )
    print(
        f"  total {out['total_s']:.1f} s (target 600), peak memory {out['peak_rss_mb']:.0f} MB "
        "(target 4096)"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
