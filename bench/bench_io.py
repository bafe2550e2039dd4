"""BVH parsing throughput: mocapkit's ``read_bvh`` side by side with other Python BVH readers.

Usage::

    python bench/bench_io.py [--data DIR] [--json] [--repeats N] [--peer-seconds S]
                              [--peer-repeats N]

Every reader starts from the file path and ends with the motion as numbers:

* ``mocapkit``      ``read_bvh(path)``: hierarchy + all channel values -> quaternions (Motion).
* ``bvhio``         ``bvhio.readAsBvh(path)``: hierarchy + one ``Pose`` per joint and frame.
* ``bvh-python``    ``Bvh(path.read_text())`` plus ``np.array(bvh.frames, float)`` (bvh-python keeps
                    the values as strings; converting them makes the work comparable).
* ``upc-pymotion``  ``BVH().load(path)``: hierarchy + Euler and position arrays.
* ``numpy split``   reference point, not a reader: ``np.array(block.split(), float)`` on the motion
                    block alone, already in memory.

mocapkit parses every file once before timing (numba compiles its parse kernel on first use, or
loads it from its cache; this also puts the files in the OS page cache), then the whole data set is
timed ``--repeats`` times and the best pass counts. The peers are pure Python and slow: each parses
one file as a warm-up, then files in name order until ``--peer-seconds`` have passed (or all files
are done); that subset is parsed ``--peer-repeats`` times in all, the best pass counts, and its MB/s
is computed on what it parsed. MB = 10^6 bytes of BVH file.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

REPO_ROOT = Path(__file__).resolve().parent.parent
TARGET_RATIO = 10.0


def default_data_dir() -> Path:
    """The shared bandai1 takes, found as the tests find shared data."""
    env = os.environ.get("MOCAPKIT_SHARED")
    root = Path(env).expanduser() if env else REPO_ROOT.parent / "shared"
    return root / "data" / "bandai1" / "data"


def _import_mocapkit() -> Callable[[Path], object]:
    try:
        from mocapkit.io.bvh import read_bvh
    except ImportError:  # run from a checkout without installing: use src/
        sys.path.insert(0, str(REPO_ROOT / "src"))
        from mocapkit.io.bvh import read_bvh
    return read_bvh


def _peers() -> list[tuple[str, Callable[[Path], object]]]:
    import bvh as bvh_python
    import bvhio
    from pymotion.io.bvh import BVH

    def run_bvhio(path: Path) -> object:
        return bvhio.readAsBvh(str(path))

    def run_bvh_python(path: Path) -> object:
        b = bvh_python.Bvh(path.read_text())
        return np.array(b.frames, dtype=np.float64)

    def run_pymotion(path: Path) -> object:
        b = BVH()
        b.load(str(path))
        return b.data

    return [("bvhio", run_bvhio), ("bvh-python", run_bvh_python), ("upc-pymotion", run_pymotion)]


def _motion_block(data: bytes) -> bytes:
    """The rows after the ``Frame Time:`` line."""
    at = data.find(b"Frame Time")
    if at < 0:
        raise ValueError("no 'Frame Time' line")
    return data[data.find(b"\n", at) + 1 :]


def _row(name: str, files: int, nbytes: int, seconds: float, note: str) -> dict:
    return {
        "name": name,
        "files": files,
        "mb": nbytes / 1e6,
        "seconds": seconds,
        "mb_per_s": nbytes / 1e6 / seconds,
        "note": note,
    }


def time_all(fn: Callable[[Any], object], items: list[Any], repeats: int) -> float:
    """Best of ``repeats`` passes of ``fn`` over all items, in seconds."""
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        for item in items:
            fn(item)
        best = min(best, time.perf_counter() - t0)
    return best


def time_budget(
    fn: Callable[[Path], object], files: list[Path], budget: float, repeats: int
) -> tuple[int, float]:
    """Parse files in order until ``budget`` seconds have passed, then parse that subset again
    ``repeats - 1`` times; returns (files in the subset, best seconds for it)."""
    fn(files[0])  # warm-up (imports, first-call caches)
    t0 = time.perf_counter()
    n = 0
    for f in files:
        fn(f)
        n += 1
        if time.perf_counter() - t0 >= budget:
            break
    first = time.perf_counter() - t0
    return n, min(first, time_all(fn, files[:n], repeats - 1) if repeats > 1 else first)


def run(
    data: Path, repeats: int, peer_seconds: float, peer_repeats: int, log: Callable[[str], None]
) -> dict:
    files = sorted(data.glob("*.bvh"))
    if not files:
        raise SystemExit(f"no .bvh files in {data} (use --data DIR, or set MOCAPKIT_SHARED)")
    sizes = [f.stat().st_size for f in files]
    total = sum(sizes)
    read_bvh = _import_mocapkit()

    log(f"warming up: mocapkit parses all {len(files)} files once (numba compile / cache load)")
    t0 = time.perf_counter()
    for f in files:
        read_bvh(f)
    log(f"  first pass: {time.perf_counter() - t0:.2f} s")
    rows = []
    best = time_all(read_bvh, files, repeats)
    rows.append(_row("mocapkit", len(files), total, best, f"all files, best of {repeats}"))
    log(f"  mocapkit: {rows[-1]['mb_per_s']:.1f} MB/s")

    for name, fn in _peers():
        try:
            n, secs = time_budget(fn, files, peer_seconds, peer_repeats)
        except Exception as e:  # a peer that cannot read some file of --data DIR: report, go on
            rows.append(
                {
                    "name": name,
                    "files": 0,
                    "mb": 0.0,
                    "seconds": None,
                    "mb_per_s": None,
                    "note": f"failed: {type(e).__name__}",
                }
            )
            log(f"  {name}: failed ({type(e).__name__}: {e})")
            continue
        rows.append(_row(name, n, sum(sizes[:n]), secs, f"first {n} files, best of {peer_repeats}"))
        log(f"  {name}: {rows[-1]['mb_per_s']:.2f} MB/s")

    blocks = [_motion_block(f.read_bytes()) for f in files]
    block_bytes = sum(len(b) for b in blocks)

    ref = time_all(lambda b: np.array(b.split(), dtype=np.float64), blocks, repeats)
    rows.append(
        _row(
            "numpy split (ref)",
            len(files),
            block_bytes,
            ref,
            f"motion blocks in memory, best of {repeats}",
        )
    )

    peers = [
        r
        for r in rows
        if r["name"] not in ("mocapkit", "numpy split (ref)") and r["mb_per_s"] is not None
    ]
    fastest = max(peers, key=lambda r: r["mb_per_s"]) if peers else None
    return {
        "data": str(data),
        "files": len(files),
        "total_mb": total / 1e6,
        "results": rows,
        "fastest_peer": fastest["name"] if fastest else None,
        "ratio_vs_fastest_peer": rows[0]["mb_per_s"] / fastest["mb_per_s"] if fastest else None,
        "target_ratio": TARGET_RATIO,
    }


WIDTHS = (18, 5, 7, 8, 8, 26)


def report_line(cells: tuple[str, ...]) -> str:
    out = []
    for i, (c, w) in enumerate(zip(cells, WIDTHS, strict=True)):
        out.append(c.ljust(w) if i in (0, len(WIDTHS) - 1) else c.rjust(w))
    return "  ".join(out).rstrip()


def format_table(report: dict) -> str:
    head = ("parser", "files", "MB", "seconds", "MB/s", "timed on")
    lines = [report_line(head)]
    lines.append(report_line(tuple("-" * w for w in WIDTHS)))
    for r in report["results"]:
        secs = "-" if r["seconds"] is None else f"{r['seconds']:.3f}"
        speed = "-" if r["mb_per_s"] is None else f"{r['mb_per_s']:.2f}"
        lines.append(
            report_line((r["name"], str(r["files"]), f"{r['mb']:.2f}", secs, speed, r["note"]))
        )
    lines.append("")
    if report["fastest_peer"] is None:
        lines.append("ratio vs fastest peer: n/a (no peer could read the files)")
    else:
        lines.append(
            f"ratio vs fastest peer ({report['fastest_peer']}): "
            f"{report['ratio_vs_fastest_peer']:.1f}x"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument(
        "--data",
        type=Path,
        default=None,
        help="folder of .bvh files (default: the shared bandai1 takes)",
    )
    ap.add_argument("--json", action="store_true", help="print the figures as JSON")
    ap.add_argument(
        "--repeats",
        type=int,
        default=5,
        help="passes over all files for mocapkit and the numpy reference (best of)",
    )
    ap.add_argument(
        "--peer-seconds",
        type=float,
        default=2.0,
        help="each peer parses files until this many seconds have passed",
    )
    ap.add_argument(
        "--peer-repeats", type=int, default=3, help="passes over each peer's files (best of)"
    )
    args = ap.parse_args(argv)
    data = args.data if args.data is not None else default_data_dir()

    def log(msg: str) -> None:
        print(msg, file=sys.stderr if args.json else sys.stdout, flush=True)

    log(f"data: {data}")
    report = run(data, max(1, args.repeats), args.peer_seconds, max(1, args.peer_repeats), log)
    if args.json:
        print(json.dumps(report, indent=2))
    else:
        print()
        print(format_table(report))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
