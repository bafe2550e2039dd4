# ruff: noqa: E402  (thread-count environment set before numpy and numba are imported)
"""Scaling of library jobs (issue #15), in one run: library clean of all bandai2 and the bandai2
graph tiles, each in-process (1 thread; 2 threads beside) and on a local Dask cluster of 2
workers x 1 thread: time, throughput (takes/s, frame pairs/s), speed-up at an equal thread
budget (2 workers x 1 thread vs in-process 1 thread; aim >= 1.8x), peak memory per worker, and
from the measured per-tile cost the projected time and memory of a 1,000,000-frame graph on 8,
32 and 128 workers.

    .venv/bin/python bench/bench_scale.py [--takes N] [--skip-clean] [--skip-graph]

Data: $MOCAPKIT_SHARED/data/bandai2/data (else ../shared beside the repository).
"""

from __future__ import annotations

import os

for _k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_k, "1")  # one thread per task everywhere: equal thread budgets

import argparse
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

from mocapkit.batch import LibraryCleanConfig, Runner, clean_library
from mocapkit.graph.distance import build_database, plan_tiles, tiled_local_minima
from mocapkit.io import read_motion


def shared_data() -> Path:
    env = os.environ.get("MOCAPKIT_SHARED")
    root = Path(env) if env else Path(__file__).resolve().parents[1].parent / "shared"
    return root / "data" / "bandai2" / "data"


def mb(n: float) -> str:
    return f"{n / 2**20:,.0f} MB"


def runners():
    yield "in-process, 1 thread", dict()
    yield "in-process, 2 threads", dict(threads_per_worker=2)
    yield "2 workers x 1 thread", dict(workers=2)


def bench_clean(lib: Path, takes: int) -> None:
    sub = Path(tempfile.mkdtemp(prefix="bench_scale_lib_"))
    files = sorted(lib.glob("*.bvh"))[:takes]
    for f in files:
        os.symlink(f, sub / f.name)
    print(f"\n== library clean: {len(files)} bandai2 takes (context by prefix, at most 8)")
    base = None
    for label, kw in runners():
        out = Path(tempfile.mkdtemp(prefix="bench_scale_out_"))
        with Runner(**kw) as r:
            t0 = time.perf_counter()
            res = clean_library(sub, out / "fixed", out / "reports", LibraryCleanConfig(),
                                runner=r)  # fmt: skip
            dt = time.perf_counter() - t0
            peak = r.stats.peak_rss_max
        base = base or dt
        print(
            f"  {label:24s} {dt:7.1f} s  {res.cleaned / dt:6.2f} takes/s  speed-up "
            f"{base / dt:4.2f}x  peak memory per worker {mb(peak)}  failed {len(res.failed)}"
        )
        for r in res.failed:
            print(f"    failed: {r['error']}")
        shutil.rmtree(out, ignore_errors=True)
    shutil.rmtree(sub, ignore_errors=True)


def bench_graph(lib: Path, takes: int) -> None:
    files = sorted(lib.glob("*.bvh"))[:takes]
    motions = [read_motion(f) for f in files]
    db = build_database(motions)
    plan = plan_tiles(db, None, 1024, None)
    pairs = plan.pairs()
    print(
        f"\n== graph tiles: {len(files)} takes, {db.num_frames} frames, stride {plan.stride}, "
        f"{plan.dtype}, {plan.num_tiles} tiles in {len(plan.tasks)} tasks, {pairs:.3g} pairs"
    )
    base = None
    per_tile = None
    for label, kw in runners():
        with Runner(**kw) as r:
            t0 = time.perf_counter()
            tiled_local_minima(db, plan.stride, plan.tile, np.dtype(plan.dtype).type, runner=r)
            dt = time.perf_counter() - t0
            peak = r.stats.peak_rss_max
            if per_tile is None:
                per_tile = r.stats.task_seconds / plan.num_tiles
        base = base or dt
        print(
            f"  {label:24s} {dt:7.1f} s  {pairs / dt:9.3g} pairs/s  speed-up {base / dt:4.2f}x"
            f"  peak memory per worker {mb(peak)} (estimate {mb(plan.memory_bytes(db))})"
        )
    # projection: 1,000,000 frames at the default stride (2), same tile, same per-tile cost;
    # memory: the estimate's per-frame part (database copy, buckets, grid) grows with N
    from mocapkit.graph.distance import _database_bytes

    N = 1_000_000
    grid = N // 2
    blocks = -(-grid // plan.tile)
    tiles = blocks * (blocks + 1) // 2
    per_frame = (_database_bytes(db) / db.num_frames + 16 + 32
                 + max(1, plan.per_bucket) * 32 / plan.bucket_frames)  # fmt: skip
    mem = plan.memory_bytes(db) + (N - db.num_frames) * per_frame
    print(
        f"\n== projection, 1,000,000-frame graph (stride 2): {tiles:,} tiles of {plan.tile}, "
        f"{per_tile * 1e3:.1f} ms per tile measured on one thread"
    )
    for w in (8, 32, 128):
        print(
            f"  {w:4d} workers: {tiles * per_tile / w / 3600:6.2f} h (tiles only, perfect "
            f"balance), memory per worker about {mb(mem)} (database copy + one tile)"
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--takes", type=int, default=750)
    ap.add_argument("--skip-clean", action="store_true")
    ap.add_argument("--skip-graph", action="store_true")
    args = ap.parse_args()
    lib = shared_data()
    if not lib.is_dir():
        raise SystemExit(f"bandai2 not found at {lib} (set MOCAPKIT_SHARED)")
    print(f"bench_scale: {os.cpu_count()} CPUs; in-process 1 thread is the baseline")
    if not args.skip_clean:
        bench_clean(lib, args.takes)
    if not args.skip_graph:
        bench_graph(lib, args.takes)


if __name__ == "__main__":
    main()
